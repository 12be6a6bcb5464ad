"""Reductions: stored frames (sessions, or frame feeds as they fill) into models and cubes;
nothing here drives a rig."""
