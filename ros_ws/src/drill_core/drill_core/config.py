"""Configuration of the rig: the typed objects behind config/*.yaml (SI units).

Values and their sources are documented in the YAML files. :func:`load_rig`
reads the whole set once; every node receives the directory and loads the same
objects, so there is one description of the well.
"""
from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass
from pathlib import Path

from drill_core.schema import ConfigError, FieldError, build, param
from drill_core.yaml_files import load_yaml, merge


# --------------------------------------------------------------------------- well
@dataclass(frozen=True)
class StringSection:
    """One section of the drill string, listed from the top (paper Table 2)."""
    name: str = param(doc="drill_pipe, collars, bha, ...")
    length_m: float = param("m", 0.0, 20000.0, lo_open=True)
    outer_diameter_m: float = param("m", 0.0, 1.0, lo_open=True)
    inner_diameter_m: float = param("m", 0.0, 1.0, lo_open=True)
    tool_joint_length_m: float = param("m", 0.0, 5.0, default=0.0)
    tool_joint_spacing_m: float = param("m", 0.0, 50.0, lo_open=True, default=9.5)
    tool_joint_outer_diameter_m: float = param("m", 0.0, 1.0, default=0.0)
    tool_joint_inner_diameter_m: float = param("m", 0.0, 1.0, default=0.0)

    def validate(self) -> None:
        if self.inner_diameter_m >= self.outer_diameter_m:
            raise FieldError("inner_diameter_m",
                             f"value {self.inner_diameter_m} m (section {self.name}) must be smaller "
                             f"than outer_diameter_m {self.outer_diameter_m} m")
        if self.tool_joint_length_m > 0.0:
            if not 0.0 < self.tool_joint_inner_diameter_m < self.tool_joint_outer_diameter_m:
                raise FieldError("tool_joint_inner_diameter_m",
                                 f"value {self.tool_joint_inner_diameter_m} m (section {self.name}) "
                                 "must lie in (0, tool_joint_outer_diameter_m "
                                 f"{self.tool_joint_outer_diameter_m} m)")
            if self.tool_joint_length_m >= self.tool_joint_spacing_m:
                raise FieldError("tool_joint_length_m",
                                 f"value {self.tool_joint_length_m} m (section {self.name}) must be "
                                 f"shorter than tool_joint_spacing_m {self.tool_joint_spacing_m} m")


@dataclass(frozen=True)
class Mud:
    """Herschel-Bulkley drilling fluid, tau = tau_y + K * gamma_dot**n."""
    density_kgm3: float = param("kg/m^3", 500.0, 3000.0)
    bulk_modulus_pa: float = param("Pa", 1.0e8, 5.0e10)
    yield_stress_pa: float = param("Pa", 0.0, 200.0, doc="string (tau_y,I); also annulus by default")
    annulus_yield_stress_pa: float = param("Pa", 0.0, 200.0)
    consistency_pa_sn: float = param("Pa s^n", 0.0, 100.0, lo_open=True)
    flow_index: float = param("1", 0.1, 1.0)


@dataclass(frozen=True)
class Turbulence:
    """Turbulent wall stress tau = a * rho * v^2 * Re_g^-b."""
    string_a: float = param("1", 0.0, 1.0, lo_open=True)
    string_b: float = param("1", 0.0, 1.0)
    annulus_model: str = param(choices=("dodge_metzner", "power_law"))
    annulus_a: float = param("1", 0.0, 1.0, lo_open=True, doc="used by power_law")
    annulus_b: float = param("1", 0.0, 1.0, doc="used by power_law")


@dataclass(frozen=True)
class Formation:
    """The open hole: the bottom annulus segment, its pore and fracture pressure at the BHP
    depth and how readily it gives or takes mud across them (docs/model.md, formation)."""
    pore_pressure_pa: float = param("Pa", 0.0, 5.0e8, doc="below it the formation flows into the well")
    fracture_pressure_pa: float = param("Pa", 0.0, 5.0e8, doc="above it the well loses mud to the formation")
    productivity_index_m3_s_pa: float = param("m^3/s/Pa", 0.0, 1.0e-6,
                                              doc="liquid influx per Pa below pore pressure")
    injectivity_index_m3_s_pa: float = param("m^3/s/Pa", 0.0, 1.0e-6,
                                             doc="loss rate per Pa above fracture pressure")

    def validate(self) -> None:
        if self.pore_pressure_pa >= self.fracture_pressure_pa:
            raise FieldError("fracture_pressure_pa",
                             f"value {self.fracture_pressure_pa:g} Pa must exceed pore_pressure_pa "
                             f"{self.pore_pressure_pa:g} Pa")


@dataclass(frozen=True)
class Well:
    """Reference well, string, fluid and surface equipment (paper Tables 2 and 4)."""
    hole_diameter_m: float = param("m", 0.0, 2.0, lo_open=True)
    segment_lengths_m: tuple[float, ...] = param("m", 0.0, 20000.0, lo_open=True)
    string: tuple[StringSection, ...] = param()
    mud: Mud = param()
    turbulence: Turbulence = param()
    steel_density_kgm3: float = param("kg/m^3", 1000.0, 20000.0)
    gravity_mps2: float = param("m/s^2", 0.0, 20.0)
    choke_coefficient_m2: float = param("m^2", 0.0, 1.0, lo_open=True, doc="C_c")
    choke_downstream_pressure_pa: float = param("Pa", 0.0, 1.0e7, doc="p_0, gauge")
    bit_nozzle_coefficient_m2: float = param("m^2", 0.0, 1.0, lo_open=True, doc="K_v")
    bha_loss_coefficient_pa_s_m3: float = param("Pa s/m^3", 0.0, 1.0e10, doc="K_b")
    hoist_stiffness_n_m: float = param("N/m", 0.0, 1.0e9, lo_open=True, doc="k_eq")
    hoist_damping_n_s_m: float = param("N s/m", 0.0, 1.0e8, doc="c_eq")
    formation: Formation = param()
    segment_hole_diameters_m: tuple[float, ...] | None = param(
        "m", 0.0, 2.0, lo_open=True, default=None,
        doc="hole diameter per annulus segment, top first (a washout); absent: hole_diameter_m")
    travelling_block_weight_n: float = param(
        "N", 0.0, 5.0e6, default=3.5e5,
        doc="the travelling block, hook and top drive: the hook load with the elevator unlatched")
    casing_shoe_depth_m: float | None = param(
        "m", 0.0, 20000.0, lo_open=True, default=None,
        doc="vertical depth of the last casing's shoe, above the open hole (the ECD there); "
            "absent: no shoe reported")

    def hole_diameters_m(self) -> tuple[float, ...]:
        """The hole diameter of each annulus segment [m], top first."""
        return self.segment_hole_diameters_m or (self.hole_diameter_m,) * len(self.segment_lengths_m)

    def validate(self) -> None:
        if len(self.segment_lengths_m) < 2:
            raise FieldError("segment_lengths_m",
                             f"value {list(self.segment_lengths_m)} must list at least 2 annulus segments")
        holes = self.segment_hole_diameters_m
        if holes is not None and len(holes) != len(self.segment_lengths_m):
            raise FieldError("segment_hole_diameters_m",
                             f"value {list(holes)} must list one diameter per annulus segment "
                             f"({len(self.segment_lengths_m)})")
        if holes is not None and min(holes) < self.hole_diameter_m:
            raise FieldError("segment_hole_diameters_m",
                             f"value {list(holes)}: a segment narrower than hole_diameter_m "
                             f"{self.hole_diameter_m} m (the bit's size; a washout only widens it)")
        for i, section in enumerate(self.string):
            key = ("outer_diameter_m" if section.outer_diameter_m >= section.tool_joint_outer_diameter_m
                   else "tool_joint_outer_diameter_m")
            widest = getattr(section, key)
            if widest >= self.hole_diameter_m:
                raise FieldError(f"string[{i}].{key}",
                                 f"value {widest} m (section {section.name}) does not fit in the hole: "
                                 f"must be smaller than hole_diameter_m {self.hole_diameter_m} m")
        shoe = self.casing_shoe_depth_m
        if shoe is not None and shoe >= sum(self.segment_lengths_m):
            raise FieldError("casing_shoe_depth_m",
                             f"value {shoe:g} m: must be above the well's bottom, "
                             f"sum(segment_lengths_m) = {sum(self.segment_lengths_m):g} m")
        string_length = sum(s.length_m for s in self.string)
        if string_length > sum(self.segment_lengths_m):
            raise FieldError("string",
                             f"total length_m {string_length:g} m exceeds the well depth: must be at "
                             f"most sum(segment_lengths_m) = {sum(self.segment_lengths_m):g} m")


# -------------------------------------------------------------------------- plant
@dataclass(frozen=True)
class MeasurementNoise:
    """Standard deviations of the four sensors (paper Table 4: sigma = W * y_nom)."""
    block_position_m: float = param("m", 0.0, 10.0)
    choke_dp_pa: float = param("Pa", 0.0, 1.0e7)
    bhp_pa: float = param("Pa", 0.0, 1.0e7)
    string_flow_m3s: float = param("m^3/s", 0.0, 1.0)


@dataclass(frozen=True)
class SurfaceSensorNoise:
    """Standard deviations of the surface-flow sensors an MPD rig adds (not in the paper)."""
    return_flow_m3s: float = param("m^3/s", 0.0, 1.0, doc="Coriolis meter on the choke line")
    pit_volume_m3: float = param("m^3", 0.0, 100.0, doc="active pit level sensor")
    bpp_flow_m3s: float = param("m^3/s", 0.0, 1.0, doc="back-pressure pump stroke counter")
    hook_load_n: float = param("N", 0.0, 1.0e6, default=2.0e3, doc="deadline load cell")
    trip_tank_volume_m3: float = param("m^3", 0.0, 10.0, default=5.0e-3,
                                       doc="trip tank level sensor (5 mm on a 1 m^2 tank)")


@dataclass(frozen=True)
class SensorBias:
    """A constant error of a sensor's reading (SI; reading = truth + bias)."""
    bhp_pa: float = param("Pa", -1.0e7, 1.0e7, default=0.0)
    choke_dp_pa: float = param("Pa", -1.0e7, 1.0e7, default=0.0)
    return_flow_m3s: float = param("m^3/s", -0.1, 0.1, default=0.0)
    string_flow_m3s: float = param("m^3/s", -0.1, 0.1, default=0.0)


@dataclass(frozen=True)
class Plant:
    """Truth-model numerics, process noise and sensors."""
    step_s: float = param("s", 0.0, 0.1, lo_open=True)
    substeps: int = param("1", 1, 100)
    sensor_period_s: float = param("s", 0.0, 10.0, lo_open=True)
    pressure_diffusion_pa_sqrt_s: float = param("Pa/s^0.5", 0.0, 1.0e6, doc="g_p")
    flow_diffusion_m3s_sqrt_s: float = param("m^3/s/s^0.5", 0.0, 1.0, doc="g_q")
    yield_regularisation_velocity_mps: float = param("m/s", 0.0, 1.0, lo_open=True)
    choke_regularisation_pa: float = param("Pa", 0.0, 1.0e6, lo_open=True)
    active_pit_volume_m3: float = param("m^3", 0.0, 1000.0, doc="mud in the active pit at the start")
    measurement_noise: MeasurementNoise = param()
    surface_sensor_noise: SurfaceSensorNoise = param()
    trip_tank_volume_m3: float = param("m^3", 0.0, 100.0, default=6.0,
                                       doc="mud in the trip tank at the start")
    jit: bool = param(default=False, doc="compile the frame and outputs functions to C "
                                         "(cached; needs a C compiler); same numbers, about "
                                         "half the frame time")
    sensor_bias: SensorBias = param(default=SensorBias(),
                                    doc="constant sensor errors (a mismatch: drill_core.mismatch)")

    def validate(self) -> None:
        ratio = self.sensor_period_s / self.step_s
        if abs(ratio - round(ratio)) > 1e-9:
            raise FieldError("sensor_period_s",
                             f"value {self.sensor_period_s} s must be a whole multiple of step_s "
                             f"{self.step_s} s")

    @property
    def steps_per_frame(self) -> int:
        """Plant steps per sensor frame."""
        return int(round(self.sensor_period_s / self.step_s))


# ---------------------------------------------------------------------- actuators
@dataclass(frozen=True)
class Lag:
    """First-order actuator with range and rate limits."""
    time_constant_s: float = param("s", 0.0, 1000.0, lo_open=True)
    minimum: float = param("SI unit of the actuator")
    maximum: float = param("SI unit of the actuator")
    rate_limit_per_s: float = param("SI unit of the actuator per s", 0.0, lo_open=True)

    def validate(self) -> None:
        if self.minimum >= self.maximum:
            raise ValueError(f"minimum {self.minimum} must be below maximum {self.maximum}")


@dataclass(frozen=True)
class Actuators:
    """Drawworks, choke, back-pressure pump and mud pump (docs/design.md §4, paper Table 4)."""
    drawworks: Lag = param(doc="block position [m]")
    block_kp: float = param("1", 0.0, 100.0, doc="block-position controller proportional gain")
    block_ki_per_s: float = param("1/s", 0.0, 100.0, doc="block-position controller integral gain")
    choke: Lag = param(doc="opening [1]")
    choke_kp: float = param("1", 0.0, 100.0, doc="PI gain, opening per unit normalised flow error")
    choke_ti_s: float = param("s", 0.0, 1000.0, lo_open=True)
    choke_flow_scale_m3s: float = param("m^3/s", 0.0, 1.0, lo_open=True,
                                        doc="flow error normalisation of the PI controller")
    bpp: Lag = param(doc="back-pressure pump flow [m^3/s]")
    mud_pump: Lag = param(doc="stand-pipe pressure [Pa]")
    watchdog_timeout_s: float = param("s", 0.0, 60.0, lo_open=True)
    choke_flow_frozen_after_samples: int = param(
        "samples", 0, 10000, default=5,
        doc="the same return-flow sample this many frames running is frozen: the flow "
            "controller falls back on the valve law (0: never)")
    choke_gauges_frozen_after_samples: int = param(
        "samples", 0, 10000, default=5,
        doc="the same choke-dp or BHP sample this many frames running is frozen: the "
            "pressure and BHP loops hold the opening as for a dropout (0: never)")
    choke_pressure_kp: float = param(
        "1", 0.0, 100.0, default=0.0,
        doc="pressure mode: PI gain, opening per unit normalised choke-dp error")
    choke_pressure_ti_s: float = param("s", 0.0, 1000.0, lo_open=True, default=2.0,
                                       doc="pressure mode: PI integral time")
    choke_pressure_scale_pa: float = param("Pa", 0.0, 1.0e7, lo_open=True, default=1.0e5,
                                           doc="pressure mode: choke-dp error normalisation")
    choke_bhp_kp: float = param("1", 0.0, 10.0, default=0.3,
                                doc="BHP mode (emergency stop): choke-dp set-point change per "
                                    "BHP error")
    choke_bhp_ti_s: float = param("s", 0.0, 1000.0, lo_open=True, default=5.0,
                                  doc="BHP mode: the outer loop's integral time")
    brake_deceleration_mps2: float = param(
        "m/s^2", 0.0, 20.0, lo_open=True, default=1.0,
        doc="emergency stop: the drawworks brake decelerates the block at this rate to rest")


# ---------------------------------------------------------------------- estimator
FRICTION_LAWS = ("quadratic", "scaled_rheology")


@dataclass(frozen=True)
class FrictionLawTuning:
    """UKF tuning that belongs to one annular friction law: its random-walk parameters
    theta_i, in the law's unit (quadratic: Pa s^2/m^2; scaled_rheology: 1, a factor), and
    the process noise of the flow states, whose momentum balances carry the law's error."""
    theta_initial: float = param("law unit", 0.0, doc="theta_i(0)")
    theta_initial_std: float = param("law unit", 0.0, lo_open=True)
    theta_process_std: float = param("law unit", 0.0, doc="per-step std of the random walk at rest")
    theta_max: float = param("law unit", 0.0, lo_open=True, doc="upper projection bound of theta")
    flow_process_std_m3s: float = param("m^3/s", 0.0, doc="per-step std of flow states")
    theta_motion_std: float = param("law unit", 0.0, default=0.0,
                                    doc="extra per-step std while the string moves at "
                                        "motion_reference_speed_mps or faster")
    theta_correlation: float = param("1", 0.0, 0.999, default=0.0,
                                     doc="correlation of the theta_i random walks and initial "
                                         "errors (near 1: one common factor)")


@dataclass(frozen=True)
class Estimator:
    """UKF tuning (paper Tables 3 and 6), SI units."""
    alpha: float = param("1", 0.0, 1.0, lo_open=True)
    beta: float = param("1", 0.0, 10.0)
    kappa_offset: float = param("1", -100.0, 100.0, doc="kappa = kappa_offset - n_x (paper: 3)")
    rig_process_std: tuple[float, ...] = param("m, m/s, m s", 0.0, doc="per-step std of z1..z3")
    pressure_process_std_pa: float = param("Pa", 0.0, doc="per-step std of pressure states")
    bottom_influx_process_std_m3s: float = param("m^3/s", 0.0, doc="per-step std of d (NMPC2)")
    annular_friction_law: str = param(
        choices=FRICTION_LAWS,
        doc="annular friction of the shared estimation model (UKF and NMPC): quadratic "
            "theta_i |v_e| v_e (paper eq. 46) or scaled_rheology theta_i F_nom,i (docs/model.md)")
    annular_friction_smoothing_mps: float = param(
        "m/s", 0.0, 1.0, lo_open=True,
        doc="scaled_rheology: yield-jump smoothing velocity of F_nom (the UKF's RK4 steps' "
            "stiffness; the NMPC predicts with nmpc.prediction_friction_smoothing_mps and "
            "nmpc.pump_off_friction_smoothing_mps)")
    quadratic_friction: FrictionLawTuning = param(doc="tuning under the quadratic law")
    scaled_rheology_friction: FrictionLawTuning = param(doc="tuning under the scaled_rheology law")
    initial_pressure_std_pa: float = param("Pa", 0.0, lo_open=True)
    initial_flow_std_m3s: float = param("m^3/s", 0.0, lo_open=True)
    measurement_noise: MeasurementNoise = param()
    nis_window: int = param("samples", 1, 10000)
    frozen_after_samples: int = param("samples", 0, 10000,
                                      doc="a channel repeating its value this often is left out "
                                          "as frozen (0: never)")
    nis_alarm_probability: float = param("1", 0.5, 0.999999)
    covariance_inflation: float = param("1", 1.0, 100.0)
    estimate_bottom_influx: bool = param(default=False)
    estimate_density_offset: bool = param(
        default=False, doc="a random-walk density offset state: every hydrostatic column is "
                           "(rho + delta_rho) g h (docs/mismatch.md)")
    initial_density_offset_std_kgm3: float = param("kg/m^3", 0.0, 500.0, lo_open=True, default=10.0)
    density_offset_process_std_kgm3: float = param("kg/m^3", 0.0, 100.0, default=1.0e-3,
                                                   doc="per-step std of the density offset")
    estimate_string_friction: bool = param(
        default=False, doc="a random-walk factor on the string's friction (docs/mismatch.md)")
    initial_string_friction_std: float = param("1", 0.0, 10.0, lo_open=True, default=0.1)
    string_friction_process_std: float = param("1", 0.0, 1.0, default=1.0e-5,
                                               doc="per-step std of the string friction factor")
    estimate_bulk_modulus: bool = param(
        default=False, doc="a random-walk factor on the effective bulk modulus, annulus and "
                           "string (always with the bottom influx; docs/mismatch.md)")
    initial_bulk_modulus_std: float = param("1", 0.0, 10.0, lo_open=True, default=0.1)
    bulk_modulus_process_std: float = param("1", 0.0, 1.0, default=1.0e-5,
                                            doc="per-step std of the bulk modulus factor")
    initial_rig_std: tuple[float, ...] = param("m, m/s, m s", 0.0, lo_open=True,
                                               default=(0.01, 0.01, 0.01),
                                               doc="initial std of z1..z3")
    initial_bottom_influx_std_m3s: float = param("m^3/s", 0.0, lo_open=True, default=1.0e-4)
    max_std_factor: float = param("1", 1.0, 1.0e6, default=10.0,
                                  doc="each state's std is capped at this times its initial std")
    motion_reference_speed_mps: float = param("m/s", 0.0, 10.0, lo_open=True, default=0.1)
    block_input: str = param(choices=("reference", "block_position"), default="reference",
                             doc="time-update input u[U_BLOCK]: drawworks reference u_r or its output u_b")
    model_steps_per_frame: int = param(
        "1", 1, 100, default=2,
        doc="RK4 steps of the time update per sensor frame; the actuators' per-plant-step "
            "outputs are averaged over each")
    jit: bool = param(default=False, doc="compile the time update to C (cached; needs a C "
                                         "compiler); same numbers, half the frame time")
    valve_law_calibration_s: float = param(
        "s", 0.0, 3600.0, lo_open=True, default=30.0,
        doc="time constant of the return-flow meter's calibration of the valve law (meter "
            "flow over the law's), applied while the rig floor has the mud pump stopped")

    def validate(self) -> None:
        for key in ("rig_process_std", "initial_rig_std"):
            if len(getattr(self, key)) != 3:
                raise FieldError(key, f"value {list(getattr(self, key))} must list 3 values "
                                 "(z1 m, z2 m/s, z3 m s)")
        if self.alpha ** 2 * self.kappa_offset <= 0.0:
            raise FieldError("kappa_offset", f"value {self.kappa_offset} must be positive "
                             "(n_x + lambda = alpha^2 kappa_offset is the sigma-point spread)")

    @property
    def friction_tuning(self) -> FrictionLawTuning:
        """Tuning of the selected annular friction law."""
        return getattr(self, f"{self.annular_friction_law}_friction")


# --------------------------------------------------------------------------- nmpc
@dataclass(frozen=True)
class InputVector:
    """A value per NMPC input [block ref m, choke flow m^3/s, bpp flow m^3/s, spp Pa]."""
    block_position_m: float = param("m")
    choke_flow_m3s: float = param("m^3/s")
    bpp_flow_m3s: float = param("m^3/s")
    spp_pa: float = param("Pa")

    def as_tuple(self) -> tuple[float, float, float, float]:
        return (self.block_position_m, self.choke_flow_m3s, self.bpp_flow_m3s, self.spp_pa)


@dataclass(frozen=True)
class ChokeDpSetpoint:
    """The NMPC's choke input when the choke is on its pressure loop (choke_control
    pressure): the choke-dp set-point, in place of the choke flow in the input vectors."""
    minimum_pa: float = param("Pa", 0.0)
    maximum_pa: float = param("Pa", 0.0, lo_open=True)
    slew_pa: float = param("Pa", 0.0, lo_open=True, doc="largest change per sample")
    span_pa: float = param("Pa", 0.0, lo_open=True, doc="u_span (eq. 55)")
    move_weight: float = param("1", 0.0, doc="r_c tilde (eq. 55)")
    time_constant_s: float = param("s", 0.0, 60.0, lo_open=True,
                                   doc="closed-loop time constant of the choke pressure loop "
                                       "as the prediction models it")
    reference_weight: float = param("1", 0.0, default=0.0, doc="r_r tilde (eq. 55)")


@dataclass(frozen=True)
class OutputVector:
    """A value per tracked output [block position m, choke dp Pa, BHP Pa]."""
    block_position_m: float = param("m")
    choke_dp_pa: float = param("Pa")
    bhp_pa: float = param("Pa")

    def as_tuple(self) -> tuple[float, float, float]:
        return (self.block_position_m, self.choke_dp_pa, self.bhp_pa)


@dataclass(frozen=True)
class Nmpc:
    """NMPC supervisor (paper eqs. 49-59, Tables 6 and 8)."""
    configuration: str = param(choices=("NMPC0", "NMPC1", "NMPC2"))
    sample_time_s: float = param("s", 0.0, 10.0, lo_open=True)
    prediction_horizon_s: float = param("s", 0.0, 120.0, lo_open=True)
    control_horizon_s: float = param("s", 0.0, 120.0, lo_open=True)
    substeps: int = param("1", 1, 100)
    integrator: str = param(choices=("rk4", "euler"))
    prediction_friction_smoothing_mps: float = param(
        "m/s", 0.0, 1.0, lo_open=True,
        doc="scaled_rheology: the prediction model's yield-jump smoothing velocity while the "
            "mud pump is planned on (docs/nmpc.md)")
    pump_off_friction_smoothing_mps: float = param(
        "m/s", 0.0, 1.0, lo_open=True,
        doc="scaled_rheology: ... while the mud pump is planned off, where every annular "
            "flow is near zero (docs/nmpc.md)")
    reference_smoothing: OutputVector = param(doc="alpha_i of eq. 59, each in [0, 1)")
    output_weight: OutputVector = param(doc="w_c tilde (eq. 55)")
    output_span: OutputVector = param(doc="y_span (eq. 55)")
    input_move_weight: InputVector = param(doc="r_c tilde (eq. 55)")
    input_span: InputVector = param(doc="u_span (eq. 55)")
    input_min: InputVector = param()
    input_max: InputVector = param()
    input_slew: InputVector = param(doc="largest |u_k - u_k-1| per sample")
    integral_weight_factor: float = param("1", 0.0, 100.0, doc="Q_c = factor * W_c (NMPC1)")
    velocity_limit_mps: float = param("m/s", 0.0, 10.0, lo_open=True)
    bhp_band_pa: float = param("Pa", 0.0, 1.0e7, lo_open=True)
    choke_dp_band_pa: float = param("Pa", 0.0, 1.0e7, lo_open=True)
    choke_dp_min_pa: float = param("Pa", 0.0, 1.0e7, doc="lowest choke dp the band may reach")
    slack_weight_velocity: float = param("1", 0.0)
    slack_weight_choke_capacity: float = param("1", 0.0)
    slack_weight_string_pressure: float = param("1", 0.0)
    slack_weight_choke_dp: float = param("1", 0.0)
    slack_weight_bhp: float = param("1", 0.0)
    slack_weight_stand_end: float = param("1", 0.0, doc="a multi-stand trip: the string past "
                                          "the stand's end by more than stand_end_allowance_m")
    stand_end_allowance_m: float = param("m", 0.0, 5.0, doc="how far past the stand's end the "
                                         "string may run before its slack is paid")
    floor_pump_on_share: float = param(
        "1", 0.0, 1.0, doc="a multi-stand trip: the OCP plans with the mud pump on (its "
        "stand-pipe pressure, the circulating friction law) while the rig floor runs it above "
        "this share of its rate, else as stopped (the bit's flow stops and starts near the "
        "ramps' middle)")
    max_iterations: int = param("1", 1, 10000)
    solver: str = param(choices=("rti", "sqpmethod", "ipopt", "fatrop"),
                        doc="rti: one Gauss-Newton step per sample (QP by HPIPM); the others "
                            "are CasADi nlpsol plugins")
    input_reference_weight: InputVector = param(
        default=InputVector(0.0, 0.0, 1.0, 1.0),
        doc="r_r tilde (eq. 49/55); u_ref = [block target, previous choke flow, 0, initial spp]")
    integral_limit_s: float = param("s", 0.0, 1.0e4, lo_open=True, default=5.0,
                                    doc="NMPC1 anti-windup: |e_i| <= limit (e in output spans x s)")
    integral_leak_time_s: float = param(
        "s", 0.0, 1.0e4, default=0.0,
        doc="NMPC1: while an output is inside its band its integral decays with this time "
            "constant (0: kept)")
    jit: bool = param(default=False, doc="compile the prediction step and its Jacobian to C "
                                         "(cached; needs a C compiler and hessian gauss-newton)")
    expand: bool = param(default=False, doc="without jit: expand the NLP's MX graph to SX "
                                            "before solving (sqpmethod, ipopt)")
    hessian: str = param(choices=("exact", "gauss-newton"), default="gauss-newton",
                         doc="Lagrangian Hessian for ipopt/sqpmethod (fatrop: always exact)")
    actuator_lags_in_model: bool = param(default=True,
                                         doc="predict with the drawworks/pump lags (docs/nmpc.md)")
    bhp_bias_gain: float = param("1", 0.0, 1.0, default=0.0,
                                 doc="offset-free BHP: share of the last one-step prediction "
                                     "error added to the model's BHP bias each sample (0: off)")
    bhp_bias_limit_pa: float = param("Pa", 0.0, 1.0e7, default=1.0e6, doc="largest |BHP bias|")
    bhp_bias_error_clip_pa: float = param("Pa", 0.0, 1.0e7, default=0.0,
                                          doc="largest |one-step prediction error| the bias "
                                              "takes in a sample: a persistent offset is "
                                              "small, a transient's error large (0: no clip)")
    block_reference: str = param(choices=("exponential", "profile"), default="exponential",
                                 doc="block-position reference over the horizon: eq. 59's "
                                     "exponential approach or the trip's motion profile")
    choke_control: str = param(choices=("flow", "pressure"), default="flow",
                               doc="the choke input: flow reference of the choke's PI flow loop "
                                   "(the paper's) or set-point of its pressure loop")
    choke_dp_setpoint: ChokeDpSetpoint | None = param(
        default=None, doc="the choke input's limits and weights with choke_control pressure")

    def validate(self) -> None:
        if self.choke_control == "pressure" and self.choke_dp_setpoint is None:
            raise FieldError("choke_dp_setpoint", "is required with choke_control pressure")
        if self.jit and self.hessian != "gauss-newton":
            raise FieldError("jit", "needs hessian gauss-newton (the compiled step has no "
                                    "second derivatives)")
        if self.control_horizon_s > self.prediction_horizon_s:
            raise ValueError("control_horizon_s must not exceed prediction_horizon_s")
        for name in ("prediction_horizon_s", "control_horizon_s"):
            ratio = getattr(self, name) / self.sample_time_s
            if abs(ratio - round(ratio)) > 1e-9:
                raise ValueError(f"{name} must be a whole multiple of sample_time_s")
        for lo, hi in zip(self.input_min.as_tuple(), self.input_max.as_tuple()):
            if lo >= hi:
                raise ValueError(f"input_min {lo} must be below input_max {hi}")
        for alpha in self.reference_smoothing.as_tuple():
            if not 0.0 <= alpha < 1.0:
                raise ValueError(f"reference_smoothing {alpha} must lie in [0, 1)")

    @property
    def prediction_steps(self) -> int:
        return int(round(self.prediction_horizon_s / self.sample_time_s))

    @property
    def control_steps(self) -> int:
        return int(round(self.control_horizon_s / self.sample_time_s))


# --------------------------------------------------------------------- protection
@dataclass(frozen=True)
class KickDetection:
    """Flow-balance kick and loss detector (drill_protection.kick_detection)."""
    window_s: float = param("s", 0.0, 600.0, lo_open=True, doc="excess flow averaged over this window")
    pressure_average_s: float = param("s", 0.0, 60.0, doc="pressures: the median of this long "
                                                          "for the compression term")
    flow_threshold_m3s: float = param("m^3/s", 0.0, 0.1, lo_open=True,
                                      doc="excess flow that raises an alarm (minus: losses)")
    confirm_s: float = param("s", 0.0, 600.0, doc="beyond the threshold this long to raise, "
                                                   "within half of it this long to clear")
    stop_trip: bool = param(doc="an alarm stops the trip (the block held) until it clears")
    pit_window_s: float = param("s", 0.0, 3600.0, doc="the pit-gain flow: least-squares slope "
                                                      "of the pit over this long (0: no pit channel)")
    baseline_time_constant_s: float = param(
        "s", 0.0, 1.0e5, default=0.0,
        doc="forgetting time of the compliances' errors learnt while the well is quiet "
            "(drill_protection.flow_baseline); 0: none")
    pressure_gap_judged_after_s: float = param(
        "s", 0.0, 3600.0, default=30.0,
        doc="a pressure gauge out this long: the balance is judged again with its last "
            "reading held (a gauge out for good does not leave the well unwatched)")


@dataclass(frozen=True)
class PumpTrip:
    """The protection's answer to an unplanned loss of circulation
    (drill_protection.pump_trip)."""
    bpp_flow_m3s: float = param("m^3/s", 0.0, 0.1,
                                doc="the back-pressure pump runs at least this while it lasts")
    static_margin_pa: float = param(
        "Pa", 0.0, 1.0e7, doc="the choke makes the friction good until the BHP without it is "
                              "this far inside the window's low edge")
    trap_max_s: float = param("s", 0.0, 600.0, doc="the choke makes the friction good for at "
                                                   "most this long (0: never)")


@dataclass(frozen=True)
class FollowingWatch:
    """An actuator that does not follow its reference (drill_protection.actuator_watch);
    the travels in the actuator's own unit (SI: m, m^3/s, 1)."""
    window_s: float = param("s", 0.0, 60.0, lo_open=True, doc="the frames judged over this long")
    reference_travel: float = param("SI", 0.0, 100.0, lo_open=True,
                                    doc="the reference moved at least this in the window ...")
    output_travel: float = param("SI", 0.0, 100.0, lo_open=True,
                                 doc="... and the output less than this: not following")
    response_s: float = param("s", 0.0, 60.0, doc="the reference's moves in the window's last "
                                                  "this long are not judged (the output's answer)")
    hold_s: float = param("s", 0.0, 600.0, doc="judged not following this long after")


@dataclass(frozen=True)
class ValveWatch:
    """A valve on its flow loop that does not move (drill_protection.actuator_watch)."""
    window_s: float = param("s", 0.0, 60.0, lo_open=True, doc="the frames judged over this long")
    flow_error_m3s: float = param("m^3/s", 0.0, 1.0, lo_open=True,
                                  doc="the flow loop's error stood at least this ...")
    output_travel: float = param("1", 0.0, 1.0, lo_open=True,
                                 doc="... and the opening moved less than this: stuck")
    range_margin: float = param("1", 0.0, 1.0, doc="an opening this near a stop of the valve's "
                                                   "range is not judged (it slows to the stop)")
    response_s: float = param("s", 0.0, 60.0, doc="the error of the window's last this long "
                                                  "is not judged (the valve's answer)")


@dataclass(frozen=True)
class PumpWatch:
    """A pump that does not deliver what it is asked for, judged from its measured flow
    against its lag's answer to the commands sent (drill_protection.actuator_watch)."""
    flow_error_m3s: float = param("m^3/s", 0.0, 1.0, lo_open=True,
                                  doc="the measured flow stood at least this under the lag's "
                                      "answer ...")
    window_s: float = param("s", 0.0, 60.0, lo_open=True, doc="... for this long: not delivering")


@dataclass(frozen=True)
class WellControl:
    """The protection's answer to a kick or losses alarm: the BHP window narrowed in steps
    (drill_protection.well_control)."""
    step_pa: float = param("Pa", 0.0, 5.0e6, lo_open=True,
                           doc="each step of the window's edge toward the other")
    interval_s: float = param("s", 0.0, 600.0, lo_open=True,
                              doc="the flow since the last step is judged this long after it")
    settle_s: float = param("s", 0.0, 600.0,
                            doc="the first seconds after a step, left out of the flow judged")
    kick_margin_pa: float = param("Pa", 0.0, 5.0e6, doc="a kick's edge goes this much further "
                                                        "once the well no longer flows")
    losses_margin_pa: float = param("Pa", 0.0, 5.0e6, doc="a loss's edge goes this much further "
                                                          "once the well no longer takes mud")
    gap_pa: float = param("Pa", 0.0, 5.0e6, doc="the narrowed window is at least this wide")
    offset_time_constant_s: float = param(
        "s", 0.0, 600.0, lo_open=True, doc="low-pass of BHP - choke dp for the choke's set-point")

    def validate(self) -> None:
        if self.settle_s >= self.interval_s:
            raise FieldError("settle_s", f"value {self.settle_s} s must be shorter than "
                                         f"interval_s {self.interval_s} s")


@dataclass(frozen=True)
class Protection:
    """Process protection between advisors and machines (docs/design.md §10)."""
    pressure_margin_pa: float = param("Pa", 0.0, 1.0e7,
                                      doc="kept clear of the well's pore and fracture pressure")
    trip_speed_max_mps: float = param("m/s", 0.0, 5.0, lo_open=True, doc="machine limit")
    trip_acceleration_max_mps2: float = param("m/s^2", 0.0, 5.0, lo_open=True)
    command_period_s: float = param("s", 0.0, 10.0, lo_open=True, doc="advisor command period")
    kick_detection: KickDetection = param()
    window_guard: bool = param(doc="outside the window (with margin) the choke and the back-"
                                   "pressure pump are driven back toward it")
    pump_trip: PumpTrip = param()
    well_control: WellControl = param()
    drawworks_watch: FollowingWatch = param(doc="the block reference held at the string while "
                                                "the drawworks does not follow it")
    choke_watch: ValveWatch = param(doc="a choke that does not move on its flow loop while "
                                        "circulation is lost: the protective stop")
    bpp_watch: PumpWatch = param(doc="a back-pressure pump that does not deliver while "
                                     "circulation is lost: the protective stop")
    frozen_after_samples: int = param(
        "samples", 0, 10000, default=5,
        doc="a gauge repeating its value this often is read as frozen and left out like a "
            "dropout (drill_protection.reading; 0: never)")
    window_guard_lead_s: float = param(
        "s", 0.0, 10.0, default=0.0,
        doc="the window guard judges the BHP this far ahead on its least-squares slope over "
            "as long (0: the BHP as measured)")


@dataclass(frozen=True)
class AutomatedMpd:
    """Automated MPD controller (drill_nmpc.automated_mpd): planned trip, model-based
    choke-dp set-point for the choke's pressure loop."""
    acceleration_mps2: float = param("m/s^2", 0.0, 5.0, lo_open=True,
                                     doc="planned trip acceleration (capped by the protection's)")
    feedforward_lead_s: float = param(
        "s", 0.0, 30.0, doc="the set-point follows the plan's string speed this much ahead")
    flow_filter_time_constant_s: float = param(
        "s", 0.0, 1.0e3, lo_open=True, doc="low-pass of the estimated bit flow")
    trim_time_constant_s: float = param("s", 0.0, 1.0e4, lo_open=True,
                                        doc="integral time of the BHP trim on the estimated error")
    trim_limit_pa: float = param("Pa", 0.0, 1.0e7, doc="largest |trim| of the choke-dp set-point")
    choke_dp_min_pa: float = param("Pa", 0.0, 1.0e7, doc="lowest choke-dp set-point")
    held_bhp_gain: float = param(
        "1", 0.0, 20.0, default=0.0,
        doc="while the mud pump stands for a connection, the set-point also adds this times "
            "the estimated BHP error (0: none, as recordings made before it ran)")


# ----------------------------------------------------------------------- the whole
@dataclass(frozen=True)
class RigConfig:
    """All configuration of one rig, loaded once."""
    well: Well
    plant: Plant
    actuators: Actuators
    estimator: Estimator
    nmpc: Nmpc
    protection: Protection
    automated_mpd: AutomatedMpd
    directory: str

    @property
    def pressure_window_pa(self) -> tuple[float, float]:
        """The BHP window the rig keeps to [Pa]: the formation's pore pressure plus the
        protection's margin, its fracture pressure less the margin."""
        f, margin = self.well.formation, self.protection.pressure_margin_pa
        return f.pore_pressure_pa + margin, f.fracture_pressure_pa - margin


_FILES = {"well": Well, "plant": Plant, "actuators": Actuators, "estimator": Estimator, "nmpc": Nmpc,
          "protection": Protection, "automated_mpd": AutomatedMpd}


def load_section(cls: type, path: str | os.PathLike) -> object:
    """Load one YAML file into the typed object ``cls``."""
    return build(cls, load_yaml(path), str(path))


def load_rig(directory: str | os.PathLike, overrides: dict[str, dict] | None = None) -> RigConfig:
    """Load config/{well,plant,actuators,estimator,nmpc,protection}.yaml from ``directory``.

    ``overrides`` maps a file stem to a mapping merged (recursively) over its YAML,
    e.g. ``{"nmpc": {"configuration": "NMPC2"}}`` from a scenario file.
    """
    directory = Path(directory)
    sections = {}
    for stem, cls in _FILES.items():
        path = directory / f"{stem}.yaml"
        data = load_yaml(path)
        if overrides and stem in overrides:
            data = merge(data, overrides[stem])
        sections[stem] = build(cls, data, str(path))
    formation, margin = sections["well"].formation, sections["protection"].pressure_margin_pa
    if formation.pore_pressure_pa + 2.0 * margin >= formation.fracture_pressure_pa:
        raise ConfigError(
            f"{directory / 'protection.yaml'}: pressure_margin_pa: value {margin:g} Pa leaves no "
            f"window: must be below half of well.yaml's formation window "
            f"{formation.fracture_pressure_pa - formation.pore_pressure_pa:g} Pa")
    return RigConfig(directory=str(directory), **sections)


def parse_settings(items) -> dict[str, dict]:
    """``--set FILE.KEY=VALUE`` items (the loop bench, ``rig sweep``) as :func:`load_rig`
    overrides: FILE a config file stem, KEY a dotted path into that file, VALUE JSON (a bare
    word is a string), e.g. ``nmpc.bhp_bias_gain=0``. Later items win. The values are
    checked, key and range named, when the configuration loads."""
    overrides: dict = {}
    for item in items:
        key, equals, text = item.partition("=")
        stem, dot, path = key.strip().partition(".")
        if not (equals and dot and path and all(path.split("."))):
            raise ConfigError(f"--set {item!r}: expected FILE.KEY=VALUE, e.g. nmpc.bhp_bias_gain=0")
        if stem not in _FILES:
            raise ConfigError(f"--set {item!r}: {stem!r} is not a configuration file; one of "
                              f"{', '.join(_FILES)}")
        try:
            value = json.loads(text)
        except json.JSONDecodeError:
            value = text.strip()
        *parents, leaf = path.split(".")
        node = overrides.setdefault(stem, {})
        for parent in parents:
            node = node.setdefault(parent, {})
            if not isinstance(node, dict):
                raise ConfigError(f"--set {item!r}: {parent!r} was set to a value above")
        node[leaf] = value
    return overrides


def replace(obj: object, **changes: object) -> object:
    """A copy of a frozen configuration object with some fields changed (re-validated)."""
    new = dataclasses.replace(obj, **changes)
    check = getattr(new, "validate", None)
    if check is not None:
        check()
    return new


__all__ = ["ConfigError", "RigConfig", "Well", "StringSection", "Mud", "Turbulence", "Plant",
           "MeasurementNoise", "SurfaceSensorNoise", "Lag", "Actuators", "Estimator", "FrictionLawTuning", "FRICTION_LAWS",
           "Nmpc", "ChokeDpSetpoint", "AutomatedMpd", "InputVector", "OutputVector", "Protection",
           "KickDetection", "Formation", "SensorBias",
           "load_rig", "load_section", "parse_settings", "replace"]
