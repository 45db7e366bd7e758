"""A split run's share (``rig run --nodes``): node and group names expanded against the
run's node set, unknown names refused with what is allowed."""
import pytest

from drill_ros import graph, topics


def _names(selection, controller="nmpc", fast=True, kind="tripping"):
    nodes = graph.run_nodes(controller, fast, kind)
    return [n.name for n in graph.host_nodes(selection, nodes)]


def test_groups_expand_to_their_members_in_this_run_in_run_order():
    assert _names("plant,actuators,recorder") == ["recorder", *topics.ACTUATORS, "plant"]
    assert _names(" protection , estimator,nmpc ") == ["estimator", "nmpc", "protection"]
    assert _names("estimator,controller,protection", controller="baseline") == [
        "estimator", "baseline", "protection"]
    assert _names("actuators", kind="drilling", controller="none") == list(
        topics.DRILLING_ACTUATORS)
    assert _names("controller", kind="drilling", controller="none") == ["driller"]


def test_an_unknown_name_is_refused_listing_the_allowed_ones():
    with pytest.raises(graph.SelectionError) as err:
        _names("plant,pump")
    message = str(err.value)
    assert "unknown node or group 'pump'" in message
    allowed = message.split("allowed: ")[1].split(", ")
    assert allowed == [*graph.HOST_GROUPS, *(n.name for n in graph.run_nodes("nmpc", True))]


def test_a_node_of_another_run_or_an_empty_share_is_refused():
    with pytest.raises(graph.SelectionError, match="node 'console' is not in this run"):
        _names("console")                      # realtime only
    with pytest.raises(graph.SelectionError, match="node 'baseline' is not in this run"):
        _names("baseline")
    with pytest.raises(graph.SelectionError, match="no node named"):
        _names(" , ")


def test_the_finishing_nodes_first_topics_have_no_other_publisher():
    """A share's watch (drill_bringup.finish_watch) takes a finishing node's end from its
    first topic's publisher going: no other node may publish it."""
    for node in graph.NODES:
        if node.plant or node.name == "estimator":
            others = [n.name for n in graph.NODES if n is not node and node.publishes[0] in n.publishes]
            assert others == [], (node.name, node.publishes[0])
