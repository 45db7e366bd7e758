"""OPC-UA writes: one field of the setpoints in force changed, the console's checks, the
supervisor's answer as the status, the automation level as the console requests it."""
import math

import pytest

from drill_hmi import console_state as cs
from drill_gateway import opcua_names as names
from drill_gateway import opcua_writes as w

ACTIVE = {"bhp_ref_pa": 6.85e7, "bhp_band_pa": 2e5, "choke_dp_ref_pa": 2e6, "choke_dp_band_pa": 5e5,
          "choke_dp_band_upper_pa": 6.63e7, "block_position_target_m": 8.0,
          "trip_speed_limit_mps": 0.5, "controller_enabled": True, "mud_pump_on": True,
          "source": "scenario", "t": 3.0}
BY_NAME = {v.name: v for v in names.VARIABLES if v.source in ("setpoints", "level")}


class Service:
    """Stands in for OperatorLink.request_setpoints: refuses a BHP over 700 bar."""

    def __init__(self):
        self.calls = []

    def __call__(self, request, what):
        self.calls.append((request, what))
        if request["bhp_ref_pa"] > 7.0e7:
            return {"accepted": False, "reason": "BHP setpoint above the fracture pressure"}
        return {"accepted": True, "reason": ""}


def test_a_request_changes_only_the_written_field():
    request = w.setpoint_request(ACTIVE, "trip_speed_limit_mps", 0.3)
    assert request["trip_speed_limit_mps"] == 0.3 and request["source"] == "opcua"
    assert all(request[k] == ACTIVE[k] for k in cs.SETPOINT_FIELDS if k != "trip_speed_limit_mps")
    assert w.setpoint_request(ACTIVE, "trip_speed_limit_mps", 0.5) is None       # no change
    assert w.setpoint_request(ACTIVE, "mud_pump_on", False)["mud_pump_on"] is False


@pytest.mark.parametrize("field, value, error", [
    ("bhp_band_pa", 0.0, "must be > 0"), ("bhp_ref_pa", -1.0, "must be >= 0"),
    ("bhp_ref_pa", math.nan, "not a finite number"), ("bhp_ref_pa", "688 bar", "expected a number"),
    ("controller_enabled", 1.0, "expected true or false")])
def test_values_the_console_would_refuse_are_refused_naming_the_field(field, value, error):
    with pytest.raises(cs.FormError, match=error) as err:
        w.setpoint_request(ACTIVE, field, value)
    assert field in str(err.value)


def test_the_supervisors_refusal_is_the_status_with_its_reason():
    service = Service()
    bhp = BY_NAME["DownholePressureSetpoint"]
    refused = w.write_setpoint(bhp, 7.2e7, ACTIVE, service)
    assert (refused.status, refused.reason) == (w.BAD_NOT_ALLOWED, "BHP setpoint above the fracture pressure")
    accepted = w.write_setpoint(bhp, 6.88e7, ACTIVE, service)
    assert accepted.good and len(service.calls) == 2
    assert service.calls[1][0]["bhp_ref_pa"] == 6.88e7 and "688" in service.calls[1][1]


def test_a_write_refused_here_never_reaches_the_service():
    service = Service()
    band = BY_NAME["DownholePressureBand"]
    assert w.write_setpoint(band, -5.0, ACTIVE, service).status == w.BAD_OUT_OF_RANGE
    assert w.write_setpoint(band, "wide", ACTIVE, service).status == w.BAD_TYPE_MISMATCH
    assert w.write_setpoint(band, 3e5, None, service).status == w.BAD_NOT_ALLOWED  # none in force
    assert w.write_setpoint(band, 2e5, ACTIVE, service).good                       # unchanged
    assert service.calls == []


def test_the_automation_level_is_checked_then_requested():
    sent = []
    set_level = lambda level: sent.append(level) or {"accepted": True, "reason": ""}  # noqa: E731
    bad = w.write_level("autopilot", set_level)
    assert bad.status == w.BAD_OUT_OF_RANGE and "manual, advisory, closed_loop" in bad.reason
    assert w.write_level("advisory", set_level).good
    assert sent == ["advisory"]
