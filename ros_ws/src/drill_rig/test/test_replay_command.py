"""``rig replay FILE [options]`` hands the replay tool its file and options (the tool reads
its argv with the program's name first)."""
from drill_bag import replay
from drill_rig import cli


def test_the_file_and_options_reach_the_replay_tool(monkeypatch):
    handed = []
    monkeypatch.setattr(replay, "main", lambda argv: handed.append(argv) or 0)
    assert cli.main(["replay", "runs/x/trip_out.mcap", "--rate", "50", "--clock", "100"]) == 0
    tool_args, ros_args = replay.split_ros_args(handed[0])
    args = replay.parse_args(tool_args[1:])
    assert (args.file, args.rate, args.clock) == ("runs/x/trip_out.mcap", 50.0, 100.0)
    assert ros_args == []
