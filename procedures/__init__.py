"""Lab-editable procedure parameters and rig descriptions.

Installed as the subpackage ``sassi_bench.procedures`` (see setup.py).
"""
