"""The advisors' setpoint book: the schedule by time and validated, a NaN BHP target
resolved once, operator requests validated, the protection's narrowed window and
well-control target followed; every change and refusal an event."""
import dataclasses
import math

import pytest

from drill_core.rig_root import rig_root
from drill_core.scenario import SetpointChange, initial_setpoints, load_scenario_config
from drill_core.hydraulics import rig_well_model
from drill_nmpc.setpoint_book import SetpointBook
from drill_nmpc.setpoint_validation import Envelope

ROOT = rig_root()
BHP_PA = 6.85e7


@pytest.fixture()
def book():
    scenario, config = load_scenario_config(ROOT / "config" / "scenarios" / "case2.yaml",
                                            ROOT / "config")
    scenario = dataclasses.replace(scenario, schedule=(
        SetpointChange(time_s=5.0, block_position_target_m=28.0),
        SetpointChange(time_s=6.0, bhp_ref_pa=8.0e7),                # above the fracture window
        SetpointChange(time_s=7.0, block_position_target_m=0.0),
    ))
    start = dataclasses.replace(initial_setpoints(config, scenario), bhp_ref_pa=math.nan)
    wm = rig_well_model(config)
    envelope = Envelope.from_config(config, wm.geometry)
    return SetpointBook(scenario, start, envelope)


def test_a_nan_bhp_target_is_the_first_finite_estimate(book):
    assert book.resolve_bhp(math.nan) == [] and not book.bhp_resolved
    events = book.resolve_bhp(BHP_PA)
    assert book.active.bhp_ref_pa == BHP_PA and book.bhp_resolved and book.changed
    assert [e.kind for e in events] == ["setpoint"] and "685.00" in events[0].text
    assert book.resolve_bhp(6.0e7) == [] and book.active.bhp_ref_pa == BHP_PA   # once only


def test_the_schedule_applies_by_time_once_and_refuses_with_a_reason(book):
    book.resolve_bhp(BHP_PA)
    book.changed = False
    assert book.advance(4.9) == [] and book.active.block_position_target_m == 0.0
    events = book.advance(6.5)
    assert book.active.block_position_target_m == 28.0
    assert book.active.bhp_ref_pa == BHP_PA                      # the refused entry changed nothing
    assert [(e.kind, e.accepted) for e in events] == [("refusal", False), ("setpoint", True)]
    assert "6 s refused" in events[0].text and "fracture" in events[0].text
    assert book.changed
    assert book.advance(6.5) == []                               # each entry once
    book.advance(7.0)
    assert book.active.block_position_target_m == 0.0


def test_an_operator_request_is_validated(book):
    ok, reason, event = book.request(book.active, "operator")
    assert not ok and "not set yet" in reason and event.kind == "refusal"
    ok, reason, event = book.request(dataclasses.replace(book.active, bhp_ref_pa=6.9e7), "console")
    assert ok and event.accepted and book.active.bhp_ref_pa == 6.9e7 and book.bhp_resolved
    ok, reason, event = book.request(dataclasses.replace(book.active, bhp_ref_pa=9.9e7), "console")
    assert not ok and book.active.bhp_ref_pa == 6.9e7 and "refused" in event.text


def test_the_protections_window_and_target_are_followed(book):
    """An echo of our reference changes nothing; a narrowed window bounds later requests;
    the protection's own target becomes the reference, its band fitted into the window,
    and a later schedule entry merges over it."""
    book.resolve_bhp(BHP_PA)
    configured = book.window_pa
    dp_ref_pa = book.active.choke_dp_ref_pa
    assert book.follow_protection(configured, BHP_PA, BHP_PA) == []
    assert book.active.bhp_ref_pa == BHP_PA and book.window_pa == configured
    window = (6.892e7, configured[1])                       # a kick: low edge raised
    book.changed = False
    events = book.follow_protection(window, 6.9045e7, BHP_PA)
    assert book.window_pa == window and book.changed
    assert book.active.bhp_ref_pa == 6.9045e7
    assert book.active.bhp_band_pa == pytest.approx(6.9045e7 - 6.892e7)   # 1.25 bar, not 2
    # the choke dp that holds the target moves one for one with it: so does its reference
    assert book.active.choke_dp_ref_pa == pytest.approx(dp_ref_pa + 6.9045e7 - BHP_PA)
    assert [(e.kind, e.accepted) for e in events] == [("setpoint", True)]
    assert "protection: well control (window 689.2-705.0 bar)" in events[0].text
    assert book.follow_protection(window, 6.9045e7, BHP_PA) == []     # taken once
    ok, reason, _ = book.request(dataclasses.replace(book.active, bhp_ref_pa=BHP_PA), "console")
    assert not ok and "pore" in reason and book.active.bhp_ref_pa == 6.9045e7
    events = book.advance(7.0)                               # the run-in entry still applies
    assert book.active.block_position_target_m == 0.0 and book.active.bhp_ref_pa == 6.9045e7


def test_a_target_outside_the_window_is_refused_with_the_reason(book):
    book.resolve_bhp(BHP_PA)
    events = book.follow_protection((6.892e7, 7.05e7), 7.5e7, BHP_PA)
    assert [(e.kind, e.accepted) for e in events] == [("refusal", False)]
    assert "well-control target refused" in events[0].text
    assert book.active.bhp_ref_pa == BHP_PA
