"""Scenario scripts: twenty-two test cases, each a set-up and a tester's script in words."""

from __future__ import annotations

import pytest

from beatlog_examples.dog.scenarios import DEMO, SUITE, Event, apply, describe, scenario
from beatlog_examples.dog.world import DogWorld


def test_the_suite_has_twenty_two_cases_of_thirty_seconds_to_three_minutes() -> None:
    assert len(SUITE) == 22
    assert len({s.name for s in SUITE}) == 22
    assert all(30.0 <= s.duration_s <= 180.0 for s in SUITE)
    tags = {tag for s in SUITE for tag in s.tags}
    wanted = {"locomotion", "obstacles", "touch", "remote", "falls", "battery", "boredom"}
    assert wanted <= tags


def test_every_event_can_be_told_in_words_and_happens_within_its_session() -> None:
    for case in (*SUITE, DEMO):
        for event in case.events:
            assert describe(event)
            assert 0 < event.at_s < case.duration_s


def test_the_procedure_tells_the_set_up_and_every_step() -> None:
    steps = scenario("low-battery").procedure()
    assert steps[0] == "Put the dog at (1.6, 2.6) m facing 86°, battery 21%."
    steps = scenario("remote-drive").procedure()
    assert steps[2].startswith("At 3 s: drive it with the remote control for 4 s")
    steps = scenario("slow-charge").procedure()
    assert steps[0].endswith("battery 19.5%.")
    assert steps[2] == "At 1 s: switch on a load that draws 1.85% of the charge per second."


def test_a_sensor_that_boots_late_is_in_the_procedure_and_the_others_start_at_once() -> None:
    late = scenario("imu-late")
    assert late.boot_s("imu") == 0.5
    assert late.boot_s("range") == 0.0
    assert late.procedure()[2] == (
        "The imu driver boots 0.5 s after the start and publishes nothing before."
    )
    assert scenario("push-over").boot_s("imu") == 0.0


def test_a_box_placed_ahead_lands_in_front_of_the_dog() -> None:
    world = DogWorld(x=1.0, y=1.0, heading=1.5707963)
    apply(world, Event(0.0, "place_ahead", ("box2", 0.8)))
    box = world.data.mocap_pos[world.model.body("box2").mocapid[0]]
    assert box[:2] == pytest.approx((1.0, 1.8), abs=1e-6)


def test_a_light_touch_a_tip_and_a_dropped_link_are_told_in_words() -> None:
    assert describe(Event(1.0, "touch", ("chin", 1.0, 0.0004))) == (
        "touch its chin, pressing 0.4 mm deep, for 1 s"
    )
    assert describe(Event(1.0, "lean", (-1, 63.0, 3.0))) == (
        "tip it 63° to its right for 3 s, then set it upright"
    )
    assert describe(Event(1.0, "drive_dropped", (0.2, 0.0, 3.0))).endswith(
        "then let the link drop without a release"
    )


def test_a_box_at_a_range_and_a_battery_swap_act_on_the_world() -> None:
    assert describe(Event(1.0, "place_at_range", ("box3", "right", 0.508))) == (
        "place box3 where the right range finder reads 0.508 m"
    )
    assert describe(Event(1.0, "swap", (0.895,))) == "swap in a battery charged to 89.5%"
    world = DogWorld()
    apply(world, Event(1.0, "swap", (0.4,)))
    assert world.battery.level == 0.4
    apply(world, Event(1.0, "place_at_range", ("box2", "front", 0.6)))
    box = world.data.mocap_pos[world.model.body("box2").mocapid[0]]
    assert box[0] > world.pose[0] + 0.6


@pytest.mark.parametrize("action", ["drive", "drive_dropped"])
def test_driving_is_not_an_action_on_the_world(action: str) -> None:
    with pytest.raises(ValueError, match=f"'{action}' is not an action on the world"):
        apply(DogWorld(), Event(1.0, action, (0.1, 0.0, 1.0)))


def test_an_unknown_scenario_names_the_known_ones() -> None:
    with pytest.raises(KeyError, match="walk-straight"):
        scenario("fetch")
