"""The MJCF model: a torso, a head and four three-joint legs, with the dog's sensors."""

from __future__ import annotations

from beatlog_examples.dog.model import load_model, sensor_slice


def test_the_model_has_twelve_actuated_leg_joints_and_the_named_sensors() -> None:
    model = load_model()
    assert model.nu == 12
    assert [model.actuator(i).name for i in range(3)] == ["fl_roll", "fl_hip", "fl_knee"]
    assert model.body("head").parentid[0] == model.body("torso").id
    assert model.opt.timestep == 0.002  # 500 Hz physics
    for name in ("range_left", "range_front", "range_right", "head", "back", "chin", "nose"):
        assert sensor_slice(model, name).stop - sensor_slice(model, name).start == 1
    assert sensor_slice(model, "accel").stop - sensor_slice(model, "accel").start == 3
