"""The console bound to every interface (0.0.0.0) with a security directory, in this
process on a ROS domain of its own: the page and its state are open to read, every action needs
the directory's token (401 without it or with a wrong one; counted and recorded as a
refusal on /operator/events, nothing done), an action with the token goes through; and a
console other machines reach does not start without a security directory."""
from __future__ import annotations

import json
import urllib.error
import urllib.request

import pytest
import rclpy
from drill_msgs.msg import OperatorEvent
from rclpy.context import Context
from rclpy.parameter import Parameter
from rig_testing import held_test_domain, spinning_node, wait_for
from std_msgs.msg import String

from drill_rig import cli
from drill_hmi.console import ConsoleNode
from drill_core import access
from drill_ros import topics
from drill_core.schema import ConfigError

pytestmark = [pytest.mark.dds, pytest.mark.filterwarnings("ignore::DeprecationWarning")]

DOMAIN_ID = held_test_domain()
TIMEOUT_S = 30.0


def console_params(**values) -> list[Parameter]:
    values = {"config_dir": str(cli.ROOT / "config"), "port": 0, "port_fallback": False,
              "mode": "realtime", **values}
    return [Parameter(k, value=v) for k, v in values.items()]


@pytest.fixture
def security(tmp_path):
    sec = access.SecurityDir(tmp_path)
    access.write_private(sec.console_token_file, (access.new_token() + "\n").encode())
    return sec


@pytest.fixture
def console(security, monkeypatch):
    make = lambda context: ConsoleNode(context=context, parameter_overrides=console_params(
        host="0.0.0.0", security_dir=str(security.path)))
    with spinning_node(DOMAIN_ID, "console", monkeypatch, make) as node:
        yield node


def request(node, path: str, body: dict | None = None, token: str | None = None):
    """(HTTP status, JSON answer) of GET ``path`` (no body) or POST ``body``."""
    url = f"http://127.0.0.1:{node.port}{path}"
    headers = {"Content-Type": "application/json"}
    if token is not None:
        headers["Authorization"] = f"Bearer {token}"
    data = None if body is None else json.dumps(body).encode()
    try:
        with urllib.request.urlopen(urllib.request.Request(url, data, headers), timeout=TIMEOUT_S) as r:
            return r.status, json.loads(r.read() or b"{}") if path.startswith("/api") else {}
    except urllib.error.HTTPError as err:
        return err.code, json.loads(err.read() or b"{}")


def test_a_console_other_machines_reach_does_not_start_without_a_security_directory(monkeypatch):
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    context = Context()
    rclpy.init(context=context, domain_id=DOMAIN_ID)
    try:
        with pytest.raises(ConfigError, match="the console on '0.0.0.0' is reachable"):
            ConsoleNode(context=context, parameter_overrides=console_params(host="0.0.0.0"))
    finally:
        rclpy.shutdown(context=context)


def test_reads_are_open_and_every_action_needs_the_token(console, security, monkeypatch):
    events, levels = [], []
    with spinning_node(DOMAIN_ID, "console_security_listener", monkeypatch) as listener:
        listener.create_subscription(OperatorEvent, topics.OPERATOR_EVENTS, events.append,
                                     topics.RELIABLE)
        listener.create_subscription(String, topics.AUTOMATION_LEVEL,
                                     lambda m: levels.append(m.data), topics.LATCHED)
        wait_for(lambda: console.link.pub_events.get_subscription_count() > 1, TIMEOUT_S,
                 "the listener's match with the console's event writer")

        assert request(console, "/")[0] == 200
        status, state = request(console, "/api/state")
        assert status == 200 and "automation" in state

        token = security.console_token()
        for given in (None, token[:-1] + "x", "Basic " + token):
            status, answer = request(console, "/api/level", {"level": "advisory"}, token=given)
            assert (status, answer["accepted"]) == (401, False), given
            assert "token" in answer["reason"]
        assert console.counters["refusals"] == 3
        wait_for(lambda: sum("no valid console token" in e.text and not e.accepted
                             for e in events) == 3, TIMEOUT_S, "three refusals on the event log")
        assert levels == []                                  # nothing was done

        status, answer = request(console, "/api/level", {"level": "advisory"}, token=token)
        assert (status, answer["accepted"]) == (200, True), answer
        wait_for(lambda: levels == ["advisory"], TIMEOUT_S, "the level the operator chose")
