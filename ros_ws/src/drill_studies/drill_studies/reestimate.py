"""Re-run the estimator on a recorded run with other tuning, and compare.

``rig reestimate RUN_DIR --config-dir DIR`` starts a fresh estimator node (fast mode,
simulated time) and a recorder on their own ROS domain, replays the run's sensor
frames, actuator frames and /clock into them, and reports the BHP estimate RMSE of
the recorded and the new estimator against the recorded truth.
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from drill_bag import mcap_io

from drill_bringup import launcher
from drill_ros import topics

REPLAYED = [topics.MEASUREMENT, "/clock", *[topics.actuator_frame(a) for a in topics.ACTUATORS]]


def bhp_estimate_rmse_pa(estimate_mcap: Path, truth_mcap: Path) -> float:
    """RMSE of the estimated BHP against the true BHP at the estimate stamps."""
    truth = {rec.publish_time_ns: msg.bhp_pa
             for rec, msg in mcap_io.decoded_messages(truth_mcap, [topics.TRUTH])}
    errors = [msg.bhp_pa - truth[rec.publish_time_ns]
              for rec, msg in mcap_io.decoded_messages(estimate_mcap, [topics.ESTIMATE])
              if rec.publish_time_ns in truth]
    return float(np.sqrt(np.mean(np.square(errors)))) if errors else float("nan")


def reestimate(run_dir: Path, config_dir: Path, rate: float, domain_id: int) -> dict:
    """Replay ``run_dir``'s recording into an estimator configured from ``config_dir``."""
    original = next(run_dir.glob("*.mcap"))
    scenario = json.loads((run_dir / "launch.json").read_text())["scenario"]
    # its own directory: re-estimations of one run may run side by side
    out_dir = Path(tempfile.mkdtemp(prefix=f"reestimate-{time.strftime('%Y%m%d-%H%M%S')}-",
                                    dir=run_dir))
    new_mcap = out_dir / "reestimate.mcap"
    common = {"config_dir": str(config_dir), "scenario": scenario, "mode": "fast",
              "use_sim_time": True}
    nodes = [launcher.NodeSpec.of("recorder",
                                  {"output": str(new_mcap), "topics": [topics.ESTIMATE], **common}),
             launcher.NodeSpec.of("estimator", common, finishes=True)]
    launch = launcher.Launch(nodes, out_dir, domain_id)
    expected = mcap_io.topics(original)[topics.MEASUREMENT].message_count
    first_ns, last_ns = mcap_io.time_range_ns(original)
    replay_cmd = [sys.executable, "-m", "drill_bag.replay", str(original), "--rate", str(rate),
                  "--topics", *REPLAYED, "--wait-for-subscribers"]
    launch.start()
    replay_log = launch.logs / "replay.log"
    replay = None
    try:
        _wait_for_subscriber(domain_id, topics.ESTIMATE, timeout_s=120.0)   # the recorder's
        with open(replay_log, "w", encoding="utf-8") as log:
            replay = subprocess.Popen(replay_cmd, env=launch.env, stdout=log,
                                      stderr=subprocess.STDOUT)
        # the estimator exits once it has estimated the recording's last sample
        ok, message = launch.watch((last_ns - first_ns) * 1e-9 / rate + 120.0,
                                   on_poll=lambda: _check(replay, replay_log))
    finally:
        if replay is not None:
            if replay.poll() is None:
                replay.terminate()
            replay.wait(timeout=10)
        codes = launch.stop()
    if not ok:
        raise RuntimeError(f"re-estimation did not finish: {message}")
    if codes.get("recorder") != 0:
        raise RuntimeError(launch.failure("recorder", codes.get("recorder")))
    return {"recorded_bhp_estimate_rmse_pa": bhp_estimate_rmse_pa(original, original),
            "new_bhp_estimate_rmse_pa": bhp_estimate_rmse_pa(new_mcap, original),
            "estimates": mcap_io.topics(new_mcap)[topics.ESTIMATE].message_count,
            "measurements": expected, "mcap": str(new_mcap)}


def _wait_for_subscriber(domain_id: int, topic: str, timeout_s: float) -> None:
    """Block until ``topic`` has a subscriber in the ROS graph, then let the reliable match
    complete: the estimator publishes as soon as the replay starts, and the recorder
    subscribes only once it has discovered the estimate topic."""
    import rclpy

    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id)
    try:
        node = rclpy.create_node("reestimate_wait", context=context)
        deadline = time.monotonic() + timeout_s
        while node.count_subscribers(topic) < 1:
            if time.monotonic() > deadline:
                raise RuntimeError(f"nothing subscribed to {topic} within {timeout_s:.0f} s")
            time.sleep(0.1)
        time.sleep(topics.MATCH_SETTLE_S)
    finally:
        rclpy.try_shutdown(context=context)


def _check(replay: subprocess.Popen, log: Path) -> None:
    """Fail the re-estimation as soon as the replay process fails."""
    code = replay.poll()
    if code not in (None, 0):
        raise RuntimeError(f"replay exited with code {code}:\n{launcher.tail(log)}")
