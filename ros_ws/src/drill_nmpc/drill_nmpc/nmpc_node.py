"""NMPC supervisor node ``nmpc`` (docs/design.md §2 and §6).

    python -m drill_nmpc.nmpc_node --ros-args -p config_dir:=... -p scenario:=.../case2.yaml \
        -p mode:=fast -p use_sim_time:=true

Subscribes /estimator/estimate (never /rig/truth) and the frames of the drawworks, the
back-pressure pump and the mud pump (/actuators/<name>/frame: block position, bpp flow,
stand-pipe pressure, the initial states of the actuator lags in the prediction model),
and /rig/command (the protection's answer: the BHP window and reference in force,
drill_nmpc.advisor_node). On the estimate stamped t_k with t_k a multiple of the
sample time t_s (fast mode: once the frames stamped t_k - t_m and the protection's answer
to the last command are in as well; realtime:
the first estimate of each new sample period, with the latest frames) it solves the OCP and publishes drill_msgs/RigCommand stamped t_k (acts
from t_k) and drill_msgs/NmpcStatus. Every due estimate is answered with a command, also
when the solve fails (the last input is held) or the estimate is unusable, so the fast-mode
lockstep never stalls.

Setpoints (drill_nmpc.setpoint_book, as every advisor keeps them): the scenario schedule
is applied by time (each entry once, when its time is reached, over the setpoints in
force); operator requests come through the validating service /set_setpoints. Refusals say why and change nothing; every accepted or refused
request (and every schedule change) goes out as drill_msgs/OperatorEvent on
/operator/events, and the setpoints in force are published latched on /setpoints whenever
they change. ``controller_enabled: false`` hands back to a safe manual state: the block
reference holds the estimated string position and the other inputs hold their last values.

Initial u_{-1} (first estimate): u_r = z1 (hold the string where it is estimated); choke
flow, back-pressure pump flow and stand-pipe pressure at the scenario's initial steady
operating point (drill_core.operating_point: design knowledge of the well, the
same point the actuators and the protection layer start from), clipped into the bounds.
(The state-consistent alternative p_in = p_I - rho g (D_bit - z1) + string friction(q_d, z2)
was 2.5 bar off the actuators' start with the UKF's initial estimate, and the protection's
rate limit then clamped the first commands.)
"""
from __future__ import annotations

import math
import sys

import numpy as np
from drill_msgs.msg import ActuatorFrame, NmpcStatus, StateEstimate
from drill_msgs.srv import SetSetpoints

from drill_core.estimation_model import BOTTOM_INFLUX
from drill_core.input_layout import U_BLOCK, U_BPP_FLOW, U_CHOKE, U_PUMP_PRESSURE, U_SIZE
from drill_ros import topics
from drill_ros.runner import run
from drill_ros.stamps import from_ns, seconds_to_ns, to_ns
from drill_nmpc.advisor_node import AdvisorNode
from drill_nmpc.advisor_ticks import NmpcTick
from drill_nmpc.prediction_model import frame_measurements, nmpc_estimation_model
from drill_nmpc.setpoint_book import as_delivered, within_speed_limits
from drill_nmpc.setpoint_messages import merge_request, to_msg
from drill_nmpc.soft_constraints import SLACK_NAMES
from drill_nmpc.solve_result import Fallback, SolveResult


class NmpcNode(AdvisorNode):
    def __init__(self, **node_options):
        super().__init__("nmpc", status_topic=topics.NMPC_NODE_STATUS, **node_options)
        ctx = self.ctx
        cfg = ctx.config
        self.em = nmpc_estimation_model(cfg)
        # Build (and, with jit, compile) the solver before any subscription exists, so the
        # graph's lockstep starts only once the supervisor can answer.
        self.tick = NmpcTick(cfg, self.em, self.start, trip=self.trip)
        self.pressure_control = cfg.nmpc.choke_control == "pressure"
        self.frame_ns = seconds_to_ns(cfg.plant.sensor_period_s)
        # The actuators' outputs (block position, bpp flow, stand-pipe pressure) are the
        # initial states of the modelled actuator lags; in fast mode the frames stamped
        # t_k - t_m are awaited (each carries the output up to t_k).
        model = self.tick.supervisor.model
        lagged = {"drawworks": model.block, "bpp": model.bpp, "mud_pump": model.pump}
        self.framed = tuple(name for name, index in lagged.items() if index is not None)
        self.frames: dict[str, dict[int, dict]] = {name: {} for name in self.framed}
        self.last_estimate_ns: int | None = None
        self.commands = 0

        self.status_pub = self.create_publisher(NmpcStatus, topics.NMPC_STATUS, topics.RELIABLE)
        self.create_service(SetSetpoints, topics.SET_SETPOINTS, self._on_set_setpoints)
        for name in lagged:      # all three, as drill_ros.graph declares; unmodelled ones unused
            self.create_subscription(ActuatorFrame, topics.actuator_frame(name),
                                     lambda msg, n=name: self._on_frame(n, msg), topics.RELIABLE)
        self.create_subscription(StateEstimate, topics.ESTIMATE, self._on_estimate, topics.RELIABLE)
        self.get_logger().info(f"nmpc ready: {self.tick.supervisor.configuration}, solver "
                               f"{self.tick.supervisor.problem.solver_name}, mode {ctx.mode}")

    # ------------------------------------------------------------------ setpoints
    def _on_set_setpoints(self, request, response):
        if self.last_estimate_ns is not None:      # rig time: the node needs no /clock
            now_ns = self.last_estimate_ns
        else:
            now_ns = 0 if self.ctx.fast else self.get_clock().now().nanoseconds
        source = request.setpoints.source or "operator"
        ok, reason, event = self.book.request(merge_request(self.book.active, request.setpoints),
                                              source)
        self.publish_events([event], now_ns, source)
        response.accepted = ok
        response.reason = reason
        response.active = to_msg(self.book.active, now_ns, "active")
        return response

    # ------------------------------------------------------------------ estimates
    def _state(self, msg: StateEstimate) -> np.ndarray | None:
        """The estimate in the supervisor model's layout (by state name), or None."""
        names = list(msg.state_names)
        mean = list(msg.mean)
        if len(names) != len(mean):
            return None
        values = dict(zip(names, mean))
        if self.em.with_disturbance and BOTTOM_INFLUX not in values:
            values[BOTTOM_INFLUX] = msg.bottom_influx_m3s \
                if math.isfinite(msg.bottom_influx_m3s) else 0.0
        try:
            x = self.em.vector(values)
        except KeyError:
            return None
        return x if np.all(np.isfinite(x)) else None

    def _on_estimate(self, msg: StateEstimate) -> None:
        stamp = to_ns(msg.header.stamp)
        self.last_estimate_ns = stamp
        if not self.gate.admit(stamp):
            return          # not a sample time (fast) or not a new sample period (realtime)
        self.offer(msg, stamp)

    def _on_frame(self, name: str, msg: ActuatorFrame) -> None:
        if name in self.framed and len(msg.output):
            stamp = to_ns(msg.header.stamp)
            slot = self.frames[name]
            slot[stamp] = frame_measurements(name, msg.output[-1], float(msg.command),
                                             float(msg.reference))   # output at t + t_m - dt
            for old in [k for k in slot if k < stamp - 10 * self.frame_ns]:
                del slot[old]
        self.try_pending()

    def _actuators(self, stamp: int):
        """(ready, measured actuator outputs) for the estimate stamped ``stamp``."""
        out = {}
        for name in self.framed:
            slot = self.frames[name]
            if self.ctx.fast:
                due = stamp - self.frame_ns
                if due < 0:
                    continue                             # first sample: no frame before t_0
                if due not in slot:
                    return False, {}
                out.update(slot[due])
            elif slot:
                latest = max(slot)
                if stamp - latest <= 2 * self.frame_ns:
                    out.update(slot[latest])
        return True, out

    def inputs_ready(self, stamp_ns: int) -> bool:
        return self._actuators(stamp_ns)[0]

    def act(self, msg: StateEstimate, stamp: int) -> None:
        actuators = self._actuators(stamp)[1]
        x = self._state(msg)
        self.follow_schedule(stamp)
        if x is None:
            self.status.error(f"estimate at {stamp * 1e-9:.3f} s unusable (missing states or "
                              "non-finite values): holding the last command")
        else:
            self.publish_events(self.book.resolve_bhp(float(x[self.em.pressure(self.em.n)])), stamp)
        plan = self._plan_setpoints(msg) if x is not None else self.book.active
        result = self.tick.step(x, plan, actuators, self.floor_at(stamp), stamp * 1e-9)
        if result is not None:      # None: nothing to hold yet, the actuators keep their safe state
            self._publish(stamp, result)

    def _plan_setpoints(self, msg: StateEstimate):
        """The setpoints to plan with: within the protection's trip-speed limits, and the
        mud pump off while the rig says it delivers nothing (a tripped pump: the string
        flow meter has no reading) though it is on."""
        active = within_speed_limits(self.book.active, self.speed_limits_mps, float(msg.mean[0]))
        return as_delivered(active, msg.string_flow_observable)

    # ------------------------------------------------------------------ outputs
    def _publish(self, stamp: int, r: SolveResult) -> None:
        assert np.all(np.isfinite(np.asarray(r.u, dtype=float))), \
            "refusing to publish a non-finite command"
        plan = np.asarray(r.planned_inputs, dtype=float).reshape(-1, U_SIZE)
        self.publish_command(self.tick.command(r, self.book.active.mud_pump_on), stamp)
        self.commands += 1

        st = NmpcStatus()
        st.header.stamp = from_ns(stamp)
        st.configuration = self.tick.supervisor.configuration
        st.solve_time_s = float(r.solve_time_s)
        st.iterations = int(r.iterations)
        st.solver_status = str(r.status)
        st.success = bool(r.success)
        st.fallback = r.fallback.value
        st.fallback_reasons = list(r.reasons)
        st.fallback_count = int(self.tick.fallback_count)
        st.cost = float(r.cost)
        st.slack_names = list(SLACK_NAMES)
        st.slack_max = [float(r.slacks.get(n, math.nan)) for n in SLACK_NAMES]
        pred = r.predicted
        st.predicted_time_s = [float(v) for v in r.predicted_time_s]
        st.predicted_bhp_pa = [float(v) for v in pred.get("bhp_pa", [])]
        st.predicted_choke_dp_pa = [float(v) for v in pred.get("choke_dp_pa", [])]
        st.predicted_block_position_m = [float(v) for v in pred.get("block_position_m", [])]
        st.predicted_string_velocity_mps = [float(v) for v in pred.get("string_velocity_mps", [])]
        st.planned_block_position_ref_m = [float(v) for v in plan[:, U_BLOCK]]
        planned = [float(v) for v in plan[:, U_CHOKE]]
        st.planned_choke_flow_m3s = [math.nan] * len(planned) if self.pressure_control else planned
        st.planned_choke_dp_ref_pa = planned if self.pressure_control else [math.nan] * len(planned)
        st.planned_bpp_flow_m3s = [float(v) for v in plan[:, U_BPP_FLOW]]
        st.planned_spp_pa = [float(v) for v in plan[:, U_PUMP_PRESSURE]]
        ref = np.asarray(r.reference, dtype=float)
        st.bhp_ref_pa = float(ref[1, 2]) if ref.shape[0] > 1 else float(self.book.active.bhp_ref_pa)
        st.block_position_ref_m = float(self.book.active.block_position_target_m)
        self.status_pub.publish(st)

        if r.fallback is not Fallback.NONE:
            self.status.error(f"solve at {stamp * 1e-9:.3f} s: fallback {r.fallback.value} "
                              f"({'; '.join((r.status, *r.reasons))})")
        mode = "manual" if not self.book.active.controller_enabled \
            else self.tick.supervisor.configuration
        self.status.mode = f"{self.ctx.mode}/{mode}"
        self.status.values = {"solve_time_s": float(r.solve_time_s),
                              "iterations": float(r.iterations),
                              "fallback_count": float(self.tick.fallback_count),
                              "rollouts": float(self.tick.rollouts),
                              "commands": float(self.commands)}
        self.status.tick(stamp)


def main(args=None) -> None:
    sys.exit(run(NmpcNode, args))


if __name__ == "__main__":
    main()
