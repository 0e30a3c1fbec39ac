"""Run configuration: TOML in, validated frozen dataclasses out.

All validation and unit conversion happens here, once, at the edge (the parameters of
each distribution and facet model are declared by its module and read through the
registries): angles are given in
degrees in TOML (keys ending in ``_deg``) and stored in radians; everything downstream
trusts these objects. Every error is a :class:`ConfigError` whose message is one line
naming the field, the offending value and what is accepted.

A run config has four tables::

    [material]                     # the microsurface
    microsurface = "v-cavity"      # or "smith": Smith's random walk (physics.md sec. 15)
    distribution = "beckmann"      # any registered distribution (microfacet/registry.py)
    alpha = 0.6                    # ... and its parameters (see `vcavity run --help`)
    facet = "interfaced_lambertian"  # any registered facet model (facet/registry.py):
    kd = 0.9                       # ... and its parameters ("conductor": eta, k; "mirror": none)
    eta = 1.5

    [incidence]
    theta_i_deg = [0, 30, 60, 80]  # polar angles of the light, degrees, in [0, 90) (default [0])
    phi_i_deg = 0                  # azimuths, degrees in [-360, 360]: one value or one per theta_i
    paths = 10_000_000             # paths per direction (2e6 works too): one value or one per theta_i

    [simulation]
    seed = 1                       # any integer >= 0
    max_order = 3                  # bounce orders kept apart in the table (1..K)
    max_bounces = 10000            # bounce cap; capped paths are reported as truncated
    track_all_orders = true        # f_inf (order 0); false stops every path after K bounces
    sensor_resolution = 57         # N: N x N equal-solid-angle cells (57 -> 3249)
    estimator = "analog"           # any registered estimator (estimators/registry.py): "exact-f1",
                                   # "paper", "exact" (specular facets: every order from the model)
    fold_symmetry = true           # default: fold wherever the mirror symmetry is exact
    target_error = 0.002           # optional: run each direction until this error ...
                                   # (exact: the model's tolerance, default 1e-3)
    max_paths = 1_000_000_000      # ... or this many paths (default: incidence.paths)
    device = "cpu"                 # or "cuda": the walk on an NVIDIA GPU (vcavity[cuda], docs/gpu.md)

    [output]
    path = "fig7.h5"               # optional; relative to the config file's folder
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vcavity.estimators import registry as estimators
from vcavity.material import ConfigError, Material, fail, validate_material
from vcavity.sensor.mirror import has_mirror_symmetry

DEFAULT_PATHS = 10_000_000
DEFAULT_MAX_ORDER = 3
# GGX tails make deep grooves common: the truncated share falls like cap^-2 with mirror
# facets and about like cap^-1.2 with diffuse ones (physics.md sec. 9: GGX alpha = 3,
# kd = 1: 1.6 % at a cap of 100, 5e-5 at 10^4), while the mean work per path hardly
# changes (the tail's expected bounce count converges).
DEFAULT_MAX_BOUNCES = 10_000
DEFAULT_SENSOR_RESOLUTION = 57
MAX_SENSOR_RESOLUTION = 2048
MAX_BOUNCES_LIMIT = 10_000_000
MAX_PATHS = 2**62  # paths and block counts stay far from int64 overflow in the kernel
# One turn each way, so both [0, 360) and (-180, 180] conventions work. Wider values are
# refused, not wrapped: the random streams are keyed by the angle's float bits, so phi and
# phi + 360 would be two different tables of one direction, and a typo like 1e300 has no
# meaningful fractional degrees left.
MAX_PHI_DEG = 360.0
#: Where the walk runs (``simulation.device``): the CPU's slot loop or numba-cuda's kernel.
DEVICES = ("cpu", "cuda")


@dataclass(frozen=True)
class Incidence:
    """One incident direction with its path budget.

    ``theta_i``, ``phi_i`` in radians (``math.radians`` of the degrees, which key the
    random streams); ``theta_i_deg``, ``phi_i_deg`` exactly as the user wrote them.
    """

    theta_i: float
    phi_i: float
    paths: int
    theta_i_deg: float | None = None
    phi_i_deg: float | None = None

    def __post_init__(self):
        if self.theta_i_deg is None:
            object.__setattr__(self, "theta_i_deg", math.degrees(self.theta_i))
        if self.phi_i_deg is None:
            object.__setattr__(self, "phi_i_deg", math.degrees(self.phi_i))


@dataclass(frozen=True)
class RunConfig:
    """A validated run: material, incident directions, simulation settings, output."""

    material: Material
    incidence: tuple[Incidence, ...]
    seed: int = 1
    max_order: int = DEFAULT_MAX_ORDER
    max_bounces: int = DEFAULT_MAX_BOUNCES
    track_all_orders: bool = True
    sensor_resolution: int = DEFAULT_SENSOR_RESOLUTION
    output: Path | None = None
    source: str = "<built-in default>"
    estimator: str = estimators.default()
    fold_symmetry: bool | None = None
    target_error: float | None = None
    max_paths: int | None = None
    device: str = "cpu"

    @property
    def orders(self) -> tuple[int, ...]:
        """The table's order axis: 0 (f_inf, when tracked) then 1..max_order."""
        head = (0,) if self.track_all_orders else ()
        return head + tuple(range(1, self.max_order + 1))

    def folds(self, direction: "Incidence") -> bool:
        """Whether the table of ``direction`` is folded about its plane of incidence.

        ``fold_symmetry`` None (the default) folds wherever the symmetry is exact
        (:func:`vcavity.sensor.mirror.has_mirror_symmetry`); validation refuses ``true``
        for a direction without it.
        """
        if self.fold_symmetry is False:
            return False
        return has_mirror_symmetry(direction.phi_i_deg, self.material.isotropic)

    def path_budget(self, direction: "Incidence") -> int:
        """Paths to trace for ``direction``: its ``paths``, or with a target error the cap."""
        if self.target_error is not None and self.max_paths is not None:
            return self.max_paths
        return direction.paths

    @property
    def effective_max_bounces(self) -> int:
        """Bounces a path may make: max_order when f_inf is not tracked."""
        return self.max_bounces if self.track_all_orders else self.max_order

    def to_dict(self) -> dict[str, Any]:
        """The resolved config as plain TOML-like data (degrees, as a user writes it)."""
        return {
            "material": self.material.to_dict(),
            "incidence": {
                "theta_i_deg": [d.theta_i_deg for d in self.incidence],
                "phi_i_deg": [d.phi_i_deg for d in self.incidence],
                "paths": [d.paths for d in self.incidence],
            },
            "simulation": {
                "seed": self.seed,
                "max_order": self.max_order,
                "max_bounces": self.max_bounces,
                "track_all_orders": self.track_all_orders,
                "sensor_resolution": self.sensor_resolution,
                "estimator": self.estimator,
                "fold_symmetry": self.fold_symmetry,
                "target_error": self.target_error,
                "max_paths": self.max_paths,
                # only off the CPU: a CPU run's config, and so the digests of its checkpoint
                # and sweep file, stay what they were before the key existed (those files
                # resume); a GPU's tables differ from the CPU's in the last bits (docs/gpu.md),
                # so the device is part of what defines a run there
                **({"device": self.device} if self.device != "cpu" else {}),
            },
            "output": {"path": str(self.output) if self.output else None},
            "source": self.source,
        }

    def replace(self, **changes) -> "RunConfig":
        """A copy with some fields changed (validated the same way)."""
        return validate(_as_raw(dataclasses.replace(self, **changes)), source=self.source)


# ---------------------------------------------------------------------------------------
# validation helpers: each returns the clean value or raises a one-line ConfigError

_fail = fail


def _number(field_name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        _fail(field_name, value, "must be a number")
    x = float(value)
    if not math.isfinite(x):
        _fail(field_name, value, "must be a finite number")
    return x


def _integer(field_name: str, value: Any, lo: int, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        _fail(field_name, value, f"must be an integer >= {lo}" + (f" and <= {hi}" if hi else ""))
    if value < lo or (hi is not None and value > hi):
        _fail(field_name, value, f"must be an integer >= {lo}" + (f" and <= {hi}" if hi else ""))
    return int(value)


def _positive(field_name: str, value: Any) -> float:
    x = _number(field_name, value)
    if not x > 0.0:
        _fail(field_name, value, "must be > 0")
    return x


def _check_keys(table_name: str, table: Any, allowed: tuple[str, ...] | None) -> dict:
    if not isinstance(table, dict):
        _fail(table_name, table, "must be a TOML table")
    for key in table if allowed is not None else ():
        if key not in allowed:
            raise ConfigError(
                f"{table_name}.{key} = {table[key]!r}: unknown key; accepted keys: {', '.join(allowed)}"
            )
    return table


def _list_or_scalar(field_name: str, value: Any, n: int | None) -> list:
    values = value if isinstance(value, list) else [value]
    if len(values) == 0:
        _fail(field_name, value, "must not be empty")
    if n is not None and len(values) not in (1, n):
        _fail(field_name, value, f"must be one value or a list of {n} (one per theta_i_deg)")
    return values


# ---------------------------------------------------------------------------------------

_INCIDENCE_KEYS = ("theta_i_deg", "phi_i_deg", "paths")
_SIMULATION_KEYS = ("seed", "max_order", "max_bounces", "track_all_orders", "sensor_resolution",
                    "estimator", "fold_symmetry", "target_error", "max_paths", "device")
_OUTPUT_KEYS = ("path",)
_TOP_KEYS = ("material", "incidence", "simulation", "output")


def _validate_incidence(raw: dict) -> tuple[Incidence, ...]:
    raw = _check_keys("incidence", raw, _INCIDENCE_KEYS)
    thetas = _list_or_scalar("incidence.theta_i_deg", raw.get("theta_i_deg", [0.0]), None)
    n = len(thetas)
    phis = _list_or_scalar("incidence.phi_i_deg", raw.get("phi_i_deg", 0.0), n)
    paths = _list_or_scalar("incidence.paths", raw.get("paths", DEFAULT_PATHS), n)
    out = []
    for k in range(n):
        t = _number("incidence.theta_i_deg", thetas[k])
        if not 0.0 <= t < 90.0:
            _fail("incidence.theta_i_deg", thetas[k], "must be in [0, 90) degrees")
        p = _number("incidence.phi_i_deg", phis[k if len(phis) > 1 else 0])
        if not -MAX_PHI_DEG <= p <= MAX_PHI_DEG:
            _fail("incidence.phi_i_deg", phis[k if len(phis) > 1 else 0],
                  f"must be in [-{MAX_PHI_DEG:g}, {MAX_PHI_DEG:g}] degrees (azimuths repeat every 360)")
        count = _integer("incidence.paths", _whole(paths[k if len(paths) > 1 else 0]), 1, MAX_PATHS)
        out.append(Incidence(theta_i=math.radians(t), phi_i=math.radians(p), paths=count,
                             theta_i_deg=thetas[k], phi_i_deg=phis[k if len(phis) > 1 else 0]))
    return tuple(out)


def validate(raw: dict, source: str = "<dict>", base_dir: Path | None = None) -> RunConfig:
    """Validate a parsed TOML document and return a :class:`RunConfig`.

    Raises
    ------
    ConfigError
        On any invalid, missing or unknown field (one-line message).
    """
    raw = _check_keys("config", raw, _TOP_KEYS)
    material = validate_material(raw.get("material", {}))
    incidence = _validate_incidence(raw.get("incidence", {}))
    sim = _check_keys("simulation", raw.get("simulation", {}), _SIMULATION_KEYS)
    seed = _integer("simulation.seed", sim.get("seed", 1), 0, 2**64 - 1)
    # Counts may be written as integral floats (2e3), as on the command line (--paths 2e3).
    max_order = _integer("simulation.max_order", _whole(sim.get("max_order", DEFAULT_MAX_ORDER)), 1, 1000)
    max_bounces = _integer("simulation.max_bounces", _whole(sim.get("max_bounces", DEFAULT_MAX_BOUNCES)), 1,
                           MAX_BOUNCES_LIMIT)
    if max_bounces < max_order:
        _fail("simulation.max_bounces", max_bounces, f"must be >= simulation.max_order ({max_order})")
    track = sim.get("track_all_orders", True)
    if not isinstance(track, bool):
        _fail("simulation.track_all_orders", track, "must be true or false")
    resolution = _integer("simulation.sensor_resolution",
                          _whole(sim.get("sensor_resolution", DEFAULT_SENSOR_RESOLUTION)), 1, MAX_SENSOR_RESOLUTION)
    estimator, fold, target_error, max_paths = _validate_estimation(sim, material, incidence, track)
    device = sim.get("device", "cpu")
    if not isinstance(device, str) or device not in DEVICES:
        _fail("simulation.device", device, f"accepted: {', '.join(repr(d) for d in DEVICES)} (default 'cpu'; "
              "'cuda' runs the walk on an NVIDIA GPU: docs/gpu.md)")
    out = _check_keys("output", raw.get("output", {}), _OUTPUT_KEYS)
    output = None
    if out.get("path") is not None:
        if not isinstance(out["path"], str) or not out["path"]:
            _fail("output.path", out["path"], "must be a non-empty string (a file path)")
        if out["path"].endswith(("/", "\\")) or Path(out["path"]).name in ("", ".", ".."):
            _fail("output.path", out["path"], "names a folder; give a file path such as 'table.h5'")
        output = Path(out["path"])
        if base_dir is not None and not output.is_absolute():
            output = base_dir / output
    config = RunConfig(
        material=material,
        incidence=incidence,
        seed=seed,
        max_order=max_order,
        max_bounces=max_bounces,
        track_all_orders=track,
        sensor_resolution=resolution,
        output=output,
        source=source,
        estimator=estimator,
        fold_symmetry=fold,
        target_error=target_error,
        max_paths=max_paths,
        device=device,
    )
    estimators.get(estimator).check(config)  # the estimator's own checks (its module says which)
    return config


def _validate_estimation(sim: dict, material: Material, incidence, track: bool):
    """``estimator``, ``fold_symmetry``, ``target_error``, ``max_paths`` of ``[simulation]``."""
    estimator = sim.get("estimator", estimators.default())
    if not isinstance(estimator, str) or estimators.find(estimator) is None:
        _fail("simulation.estimator", estimator, f"accepted: {', '.join(repr(e) for e in estimators.names())}")
    fold = sim.get("fold_symmetry")
    if fold is not None and not isinstance(fold, bool):
        _fail("simulation.fold_symmetry", fold, "must be true or false (default: fold wherever "
              "the mirror symmetry about the plane of incidence is exact)")
    if fold:
        for d in incidence:
            if not has_mirror_symmetry(d.phi_i_deg, material.isotropic):
                step = "45" if material.isotropic else "90"
                kind = "an isotropic" if material.isotropic else "an anisotropic"
                _fail("simulation.fold_symmetry", fold,
                      f"needs phi_i_deg a multiple of {step} for {kind} material (the plane of "
                      f"incidence must be a mirror plane of the BRDF and of the sensor grid), "
                      f"got phi_i_deg = {d.phi_i_deg!r}; isotropic materials do not depend on "
                      f"phi_i: simulate them at phi_i_deg = 0")
    target_error = sim.get("target_error")
    if target_error is not None:
        target_error = _number("simulation.target_error", target_error)
        if not 0.0 < target_error < 1.0:
            _fail("simulation.target_error", sim["target_error"], "must be in (0, 1) (a relative error)")
        if not track:
            _fail("simulation.target_error", sim["target_error"], "needs track_all_orders = true "
                  "(the stop rule measures the error of f_inf)")
    max_paths = sim.get("max_paths")
    if max_paths is not None:
        max_paths = _integer("simulation.max_paths", _whole(max_paths), 1, MAX_PATHS)
        if target_error is None:
            _fail("simulation.max_paths", sim["max_paths"], "applies only with simulation.target_error "
                  "(otherwise incidence.paths is the number of paths)")
    return estimator, fold, target_error, max_paths


def _whole(value: Any) -> Any:
    """A float with an integral value (``2e9`` in TOML) as an int; anything else as it is
    (huge floats too, so that the error message shows ``1e+300``, not 301 digits)."""
    if isinstance(value, float) and math.isfinite(value) and abs(value) < 2**63 and value == int(value):
        return int(value)
    return value


#: The largest config or sweep file read (bytes): far above any real one (a 1000-value
#: axis is ~10 kB), so that ``/dev/zero`` or ``<(yes)`` is refused instead of read forever.
MAX_CONFIG_BYTES = 1 << 20


def read_toml_text(path: Path, what: str = "config file") -> str:
    """The text of a TOML file the user named: a regular file or a pipe (``<(cat c.toml)``).

    Raises
    ------
    ValueError
        One line naming ``what`` and the path: unreadable, a device, a folder or a socket,
        larger than :data:`MAX_CONFIG_BYTES`, or not UTF-8.
    """
    import os
    import stat

    shown = f"{what} {str(path)!r}"
    try:
        with open(path, "rb") as handle:
            mode = os.fstat(handle.fileno()).st_mode
            if not (stat.S_ISREG(mode) or stat.S_ISFIFO(mode)):
                kind = "a character device" if stat.S_ISCHR(mode) else "a block device" if stat.S_ISBLK(mode) \
                    else "a socket" if stat.S_ISSOCK(mode) else "not a regular file"
                raise ValueError(f"{shown}: is {kind}; a TOML file (or a pipe) is expected")
            data = handle.read(MAX_CONFIG_BYTES + 1)
    except OSError as exc:
        raise ValueError(f"{shown}: cannot read it ({exc.strerror or exc})") from None
    if len(data) > MAX_CONFIG_BYTES:
        raise ValueError(f"{shown}: larger than {MAX_CONFIG_BYTES // (1 << 20)} MiB; not a TOML config")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{shown}: not UTF-8 text; a TOML file is expected") from None


def load(path: str | Path) -> RunConfig:
    """Read and validate a TOML run config.

    Raises
    ------
    ConfigError
        Unreadable file (or a device, or over :data:`MAX_CONFIG_BYTES`), TOML syntax error
        (with line), or invalid content.
    """
    path = Path(path)
    try:
        text = read_toml_text(path)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"config file {str(path)!r}: invalid TOML: {exc}") from None
    return validate(raw, source=str(path), base_dir=path.parent)


#: The built-in default run: the material of IL paper figure 7(b) (Beckmann alpha = 0.6,
#: kd = 0.9, eta = 1.5) at a few incident angles.
DEFAULT_RAW: dict[str, Any] = {
    "material": {"distribution": "beckmann", "alpha": 0.6, "facet": "interfaced_lambertian", "kd": 0.9, "eta": 1.5},
    "incidence": {"theta_i_deg": [0.0, 30.0, 60.0, 80.0], "phi_i_deg": 0.0, "paths": DEFAULT_PATHS},
    "simulation": {"seed": 1, "max_order": DEFAULT_MAX_ORDER},
}


def default_config() -> RunConfig:
    """The built-in default run (IL paper fig. 7b material)."""
    return validate(DEFAULT_RAW, source="<built-in default: IL paper fig. 7b>")


def _as_raw(cfg: RunConfig) -> dict[str, Any]:
    d = cfg.to_dict()
    d.pop("source")
    if d["output"]["path"] is None:
        d["output"] = {}
    return d


__all__ = ["ConfigError", "DEFAULT_RAW", "DEVICES", "Incidence", "Material", "RunConfig", "default_config", "load",
           "read_toml_text", "validate"]
