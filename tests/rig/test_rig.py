"""The rig's handles: a scene already in front is not asked for again."""

from __future__ import annotations

import dataclasses

from sassi_bench import open_rig
from sassi_bench.rig.scene_pose import ScenePose


def test_a_static_scene_in_front_is_placed_once_and_a_pose_always_moves_it():
    asked: list = []
    rig = dataclasses.replace(
        open_rig("sim"), scene_setter=lambda *args: asked.append(args), scene=None
    )  # as a hardware rig opens: nothing known in front
    rig.set_scene("white")
    rig.set_scene("white")
    assert asked == [("white",)]
    shifted = ScenePose(shift_px=(3.0, 0.0))
    rig.set_scene("white", shifted)
    rig.set_scene("white", shifted)  # a moving scene is a pose per frame: each one is set
    rig.set_scene("white")  # back to the static scene after a pose
    rig.set_scene("colorchecker")
    rig.set_scene("white")
    assert asked == [
        ("white",),
        ("white", shifted),
        ("white", shifted),
        ("white",),
        ("colorchecker",),
        ("white",),
    ]
    assert rig.scene == "white"
