"""Trip motion profile: the block reference's planned path to a target (plain Python),
shared by the automated-MPD controller and the NMPC's block reference trajectory."""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass
class MotionProfile:
    """Block reference moving toward a target: trapezoidal speed, exact stop. Each sample
    the speed changes by at most acceleration * t_s and the reference moves by the new
    speed * t_s: the process protection's reading of reference speed and acceleration."""
    position_m: float
    speed_mps: float = 0.0

    def step(self, target_m: float, speed_max_mps: float, acceleration_mps2: float,
             dt_s: float) -> None:
        """Advance one sample: accelerate toward the cruise speed, brake to stop on target."""
        remaining = target_m - self.position_m
        dv = acceleration_mps2 * dt_s
        # the fastest speed n dv that still stops on target in steps n dv, (n-1) dv, ..., dv
        # (distance dv dt n (n + 1) / 2)
        steps = math.sqrt(0.25 + 2.0 * abs(remaining) / (dv * dt_s)) - 0.5 if dv > 0.0 \
            else math.inf
        braking = dv * steps
        wanted = math.copysign(min(speed_max_mps, braking), remaining) if remaining else 0.0
        speed = min(max(wanted, self.speed_mps - dv), self.speed_mps + dv)
        move = speed * dt_s              # the reference moves at the sample's new speed
        if abs(move) >= abs(remaining) or (remaining == 0.0):
            self.position_m, self.speed_mps = target_m, 0.0
            return
        self.position_m += move
        self.speed_mps = speed

    def ahead(self, target_m: float, speed_max_mps: float, acceleration_mps2: float,
              dt_s: float, samples: int) -> list["MotionProfile"]:
        """This and the next ``samples`` samples' states (a copy is stepped)."""
        ghost = MotionProfile(self.position_m, self.speed_mps)
        out = [MotionProfile(ghost.position_m, ghost.speed_mps)]
        for _ in range(samples):
            ghost.step(target_m, speed_max_mps, acceleration_mps2, dt_s)
            out.append(MotionProfile(ghost.position_m, ghost.speed_mps))
        return out

    def speeds_ahead(self, target_m: float, speed_max_mps: float, acceleration_mps2: float,
                     dt_s: float, samples: int) -> list[float]:
        """The profile's speed at this and the next ``samples`` samples (a copy is stepped)."""
        return [state.speed_mps for state in
                self.ahead(target_m, speed_max_mps, acceleration_mps2, dt_s, samples)]
