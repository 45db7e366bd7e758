"""Plant-model mismatch: how the rig's true well differs from the model every controller,
estimator and the protection read (config/well.yaml, plant.yaml).

A :class:`Mismatch` scales or shifts the mud report's properties, the choke's valve
coefficient, the hole per annulus segment (a washout) and the sensors. Only the plant and
the actuators are given it (a scenario's ``truth:`` section or ``rig run --mismatch``;
the launcher hands it to them alone, docs/mismatch.md); :func:`truth_config` makes their
configuration from the model's. ``config/mismatch.yaml`` holds the named suite and the
distributions of the seeded random draws (:func:`draw`).
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drill_core.config import (MeasurementNoise, Plant, RigConfig, SensorBias,
                               SurfaceSensorNoise, Well)
from drill_core.schema import ConfigError, build, param
from drill_core.yaml_files import load_yaml

SUITE_FILE = "mismatch.yaml"


@dataclass(frozen=True)
class Mismatch:
    """The true plant against the model: each factor multiplies the model's value, each
    offset adds to it (1 and 0: the model's own)."""
    density_factor: float = param("1", 0.8, 1.2, default=1.0, doc="mud density")
    yield_stress_factor: float = param("1", 0.0, 5.0, default=1.0,
                                       doc="yield stress, string and annulus")
    consistency_factor: float = param("1", 0.1, 10.0, default=1.0, doc="consistency K")
    flow_index_offset: float = param("1", -0.3, 0.3, default=0.0, doc="flow index n")
    bulk_modulus_factor: float = param("1", 0.3, 3.0, default=1.0,
                                       doc="effective bulk modulus (mud and wellbore)")
    choke_coefficient_factor: float = param("1", 0.3, 3.0, default=1.0,
                                            doc="the choke's valve coefficient C_c")
    hole_diameter_factors: tuple[float, ...] | None = param(
        "1", 1.0, 2.0, default=None,
        doc="hole diameter per annulus segment, top first (a washout); absent: gauge hole")
    sensor_noise_factor: float = param("1", 0.0, 10.0, default=1.0,
                                       doc="every sensor's noise standard deviation")
    sensor_bias: SensorBias = param(default=SensorBias())

    def changes(self) -> dict:
        """The fields that differ from the model's own, as a mapping :func:`mismatch_from`
        reads back (the run's record of its plant)."""
        own = Mismatch()
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)
                if getattr(self, f.name) != getattr(own, f.name)}

    @property
    def is_model(self) -> bool:
        return not self.changes()


def _plain(value):
    if dataclasses.is_dataclass(value):
        return {k: v for k, v in dataclasses.asdict(value).items() if v != 0.0}
    return list(value) if isinstance(value, tuple) else value


def mismatch_from(data, source: str = "<memory>") -> Mismatch:
    """A mismatch from its mapping (keys as :class:`Mismatch`), checked."""
    return build(Mismatch, data or {}, source)


def truth_config(config: RigConfig, mismatch: Mismatch) -> RigConfig:
    """The plant's configuration: ``config`` (the model's) with ``mismatch`` applied."""
    well, plant, m = config.well, config.plant, mismatch
    mud = well.mud
    flow_index = mud.flow_index + m.flow_index_offset
    if not 0.1 <= flow_index <= 1.0:
        raise ConfigError(f"truth: flow_index_offset: value {m.flow_index_offset:g} puts the "
                          f"flow index at {flow_index:g}, outside [0.1, 1]")
    true_mud = dataclasses.replace(
        mud, density_kgm3=mud.density_kgm3 * m.density_factor,
        yield_stress_pa=mud.yield_stress_pa * m.yield_stress_factor,
        annulus_yield_stress_pa=mud.annulus_yield_stress_pa * m.yield_stress_factor,
        consistency_pa_sn=mud.consistency_pa_sn * m.consistency_factor,
        flow_index=flow_index, bulk_modulus_pa=mud.bulk_modulus_pa * m.bulk_modulus_factor)
    holes = well.hole_diameters_m()
    if m.hole_diameter_factors is not None:
        if len(m.hole_diameter_factors) != len(holes):
            raise ConfigError(f"truth: hole_diameter_factors: value {list(m.hole_diameter_factors)} "
                              f"must list one factor per annulus segment ({len(holes)})")
        holes = tuple(d * f for d, f in zip(holes, m.hole_diameter_factors))
    true_well = dataclasses.replace(
        well, mud=true_mud, choke_coefficient_m2=well.choke_coefficient_m2 * m.choke_coefficient_factor,
        segment_hole_diameters_m=holes if m.hole_diameter_factors is not None
        else well.segment_hole_diameters_m)
    scale = m.sensor_noise_factor
    true_plant = dataclasses.replace(
        plant, measurement_noise=_scaled(plant.measurement_noise, MeasurementNoise, scale),
        surface_sensor_noise=_scaled(plant.surface_sensor_noise, SurfaceSensorNoise, scale),
        sensor_bias=SensorBias(**{f.name: getattr(plant.sensor_bias, f.name)
                                  + getattr(m.sensor_bias, f.name)
                                  for f in dataclasses.fields(SensorBias)}))
    # every value of the plant's well and sensors checked against its range again
    return dataclasses.replace(config, well=_checked(Well, true_well),
                               plant=_checked(Plant, true_plant))


def _checked(cls, obj):
    return build(cls, dataclasses.asdict(obj), "truth (the plant's mismatch applied)")


def _scaled(noise, cls, factor: float):
    return cls(**{f.name: getattr(noise, f.name) * factor for f in dataclasses.fields(cls)})


def write_truth_file(path: str | Path, name: str, mismatch: Mismatch) -> None:
    """The file the launcher hands the plant's side of a run: {name, mismatch}."""
    Path(path).write_text(json.dumps({"name": name, "mismatch": mismatch.changes()}, indent=2))


def read_truth_file(path: str | Path) -> tuple[str, Mismatch]:
    """(name, mismatch) of a file :func:`write_truth_file` wrote."""
    data = load_yaml(path)
    if not isinstance(data, dict) or set(data) != {"name", "mismatch"}:
        raise ConfigError(f"{path}: <top>: expected the keys name, mismatch")
    return str(data["name"]), mismatch_from(data["mismatch"], str(path))


# ------------------------------------------------------------------ the suite, the draws
@dataclass(frozen=True)
class Spread:
    """A draw's distribution of one Mismatch field: normal about its own value (factors:
    log-normal, ``sd`` the standard deviation of the log), cut at ``limit`` sds."""
    sd: float = param("1", 0.0)
    log_normal: bool = param(default=False)
    limit: float = param("1", 0.0, 10.0, lo_open=True, default=2.5)


@dataclass(frozen=True)
class Draws:
    """The distributions of ``rig sweep --mismatch-draws`` (config/mismatch.yaml ``draws``)."""
    density_factor: Spread = param()
    yield_stress_factor: Spread = param()
    consistency_factor: Spread = param()
    flow_index_offset: Spread = param()
    bulk_modulus_factor: Spread = param()
    choke_coefficient_factor: Spread = param()


def load_suite(config_dir: str | Path) -> tuple[dict[str, Mismatch], dict[str, str], Draws]:
    """config/mismatch.yaml: the named members (name -> mismatch), each member's
    description, and the draws' distributions."""
    path = Path(config_dir) / SUITE_FILE
    data = load_yaml(path)
    if not isinstance(data, dict) or set(data) != {"members", "draws"}:
        raise ConfigError(f"{path}: <top>: expected the keys members, draws")
    members, described = {}, {}
    for name, entry in (data["members"] or {}).items():
        if not isinstance(entry, dict) or "description" not in entry:
            raise ConfigError(f"{path}: members.{name}: expected a mapping with a description")
        entry = dict(entry)
        described[name] = str(entry.pop("description"))
        members[name] = build(Mismatch, entry, str(path), f"members.{name}")
    return members, described, build(Draws, data["draws"], str(path), "draws")


def resolve(spec, config_dir: str | Path, source: str = "truth") -> tuple[str, Mismatch]:
    """A scenario's ``truth:`` (a suite member's name, or a mapping of Mismatch keys, or a
    ``draw:N`` of the suite's distributions) as (name, mismatch)."""
    if isinstance(spec, str):
        if spec.startswith("draw:"):
            index = spec.partition(":")[2]
            if not index.isdigit():
                raise ConfigError(f"{source}: value {spec!r}: a draw is draw:N, N a whole number")
            return spec, draw(load_suite(config_dir)[2], int(index))
        members = load_suite(config_dir)[0]
        if spec not in members:
            raise ConfigError(f"{source}: value {spec!r} is not a member of "
                              f"{Path(config_dir) / SUITE_FILE}; one of {', '.join(members)}")
        return spec, members[spec]
    return "inline", mismatch_from(spec, source)


# A fixed root, so draw N is the same mismatch on every machine and in every sweep.
DRAW_SEED = 20261201


def draw(draws: Draws, index: int) -> Mismatch:
    """Draw ``index`` of the suite's distributions (reproducible: the same index, the same
    mismatch)."""
    rng = np.random.default_rng([DRAW_SEED, index])
    values = {}
    for field in dataclasses.fields(Draws):
        spread: Spread = getattr(draws, field.name)
        z = float(np.clip(rng.standard_normal(), -spread.limit, spread.limit))
        own = getattr(Mismatch(), field.name)
        values[field.name] = own * math.exp(spread.sd * z) if spread.log_normal \
            else own + spread.sd * z
    return build(Mismatch, values, f"draw:{index}")
