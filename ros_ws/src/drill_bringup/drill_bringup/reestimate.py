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
import time
from pathlib import Path

import numpy as np

from drill_bringup import launcher, mcap_io
from drill_core.ros import topics

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
    out_dir = run_dir / f"reestimate-{time.strftime('%Y%m%d-%H%M%S')}"
    new_mcap = out_dir / "reestimate.mcap"
    common = {"config_dir": str(config_dir), "scenario": scenario, "mode": "fast",
              "use_sim_time": True}
    nodes = [launcher.NodeSpec("recorder", "drill_bringup.recorder",
                               {"output": str(new_mcap), "topics": [topics.ESTIMATE], **common}),
             launcher.NodeSpec("estimator", "drill_estimator.estimator_node", dict(common))]
    launch = launcher.Launch(nodes, out_dir, domain_id)
    launch.start()
    expected = mcap_io.topics(original)[topics.MEASUREMENT].message_count
    replay_cmd = [sys.executable, "-m", "drill_bringup.replay", str(original), "--rate", str(rate),
                  "--topics", *REPLAYED, "--wait-for-subscribers"]
    try:
        count = _count_estimates(domain_id, expected, replay_cmd, launch.env)
    finally:
        codes = launch.stop()
    if codes.get("recorder") != 0:
        raise RuntimeError(launch.failure("recorder", codes.get("recorder")))
    return {"recorded_bhp_estimate_rmse_pa": bhp_estimate_rmse_pa(original, original),
            "new_bhp_estimate_rmse_pa": bhp_estimate_rmse_pa(new_mcap, original),
            "estimates": count, "measurements": expected, "mcap": str(new_mcap)}


def _count_estimates(domain_id: int, expected: int, replay_cmd: list, env: dict,
                     idle_timeout_s: float = 30.0) -> int:
    """Run the replay while counting the new estimator's estimates until all arrived."""
    import rclpy
    from drill_msgs.msg import StateEstimate

    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id)
    node = rclpy.create_node("reestimate_monitor", context=context)
    received = []
    node.create_subscription(StateEstimate, topics.ESTIMATE, received.append, topics.RELIABLE)
    executor = rclpy.executors.SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        replay = subprocess.Popen(replay_cmd, env=env, stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, text=True)
        last_count, last_change = 0, time.monotonic()
        while len(received) < expected and time.monotonic() - last_change < idle_timeout_s:
            executor.spin_once(timeout_sec=0.1)
            if len(received) != last_count:
                last_count, last_change = len(received), time.monotonic()
            if replay.poll() not in (None, 0):
                raise RuntimeError(f"replay failed: {replay.stdout.read()[-2000:]}")
        replay.wait(timeout=60)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    return len(received)
