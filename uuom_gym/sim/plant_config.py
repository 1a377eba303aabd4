"""Configuration of one plant (:class:`PlantConfig`): what the vehicle file does not fix, and its validation."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from uuom_core.vehicle import VehicleParams

# fields that default to the vehicle's value (geometry lives once, in VehicleParams; a plant may override it)
_FROM_VEHICLE = ("chain_length_m", "hook_mass_kg")


class PlantConfigError(ValueError):
    """A plant configuration (or command) that is out of its valid range."""


@dataclass(frozen=True)
class PlantConfig:
    """Configuration of one plant: what the vehicle file does not fix.

    Attributes
    ----------
    load_kg : float
        Payload hanging on the chains (kg), 0 .. 1.5 x rated load.
    running_resistance : float or None
        True running-resistance coefficient mu of this plant; None = the vehicle's nominal value.
    adhesion : float or None
        Drive-wheel / rail adhesion coefficient; None = ``vehicle.adhesion_dry``.
    wheel_wear_m : float
        Radius lost to wear by the drive wheels; effective drive radius = nominal - wear.
    physics_hz : float
        Physics rate (>= 100 Hz; default 200 Hz).
    chain_length_m : float or None
        Length of the load chains (pendulum length of the swinging load); None = ``vehicle.chain_length_m``.
    anti_sway_damping_ratio : float
        Damping ratio of the load swing given by the anti-sway damper (with the train held).
    coupler_stiffness_npm, coupler_damping_nspm : float
        Compliant coupler between the drive section and the lifting-beam section.
    drive_inertia_kgm2 : float
        Rotating inertia of all drive wheels plus motor rotors reflected to the wheel shaft (downstream of the
        torque transducer, so in stick it adds ``J/r^2`` of inertia the estimator model does not have).
    max_drive_speed_mps : float
        Drive-wheel surface speed at which the motors' torque has fallen to zero (linear taper over the last 10 %).
    hook_mass_kg : float or None
        Hook block / spreader that always hangs on the chains (part of the empty mass); None =
        ``vehicle.hook_mass_kg``.
    rail_friction : float
        Contact friction of the carrying wheels on the rail flange. High, because the brake force (clamped brake
        shoes in the real brake car) is routed through these wheels.
    solver_iterations : int
        pymunk solver iterations.
    settle_s : float
        Time the train is held by the brake at construction so couplers and contacts settle; then t = 0.
    track_energy : bool
        Keep the energy books (:attr:`MonorailPlant.energy`): traction work and the work dissipated by running
        resistance, brakes and dampers. Costs about twice the per-tick time; for tests and analysis.
    """

    load_kg: float = 0.0
    running_resistance: float | None = None
    adhesion: float | None = None
    wheel_wear_m: float = 0.0
    physics_hz: float = 200.0
    chain_length_m: float | None = None
    anti_sway_damping_ratio: float = 0.05
    coupler_stiffness_npm: float = 2.0e7
    coupler_damping_nspm: float = 2.0e5
    drive_inertia_kgm2: float = 2.0
    max_drive_speed_mps: float = 2.6
    hook_mass_kg: float | None = None
    rail_friction: float = 3.0
    solver_iterations: int = 20
    settle_s: float = 1.0
    track_energy: bool = False

    def resolved(self, vehicle: VehicleParams) -> "PlantConfig":
        """This configuration with the fields left to the vehicle (None) filled in from ``vehicle``."""
        changes = {name: getattr(vehicle, name) for name in _FROM_VEHICLE if getattr(self, name) is None}
        return replace(self, **changes) if changes else self

    def validate(self, vehicle: VehicleParams) -> None:
        """Raise :class:`PlantConfigError` naming the first impossible value."""
        def bad(name: str, why: str) -> None:
            raise PlantConfigError(f"PlantConfig.{name} {why}, got {getattr(self, name)!r}")

        for f in fields(self):
            v = getattr(self, f.name)
            if v is None or f.name == "track_energy":
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                bad(f.name, "must be a finite number")
        if not 0.0 <= self.load_kg <= 1.5 * max(vehicle.rated_load_kg, 1.0):
            bad("load_kg", f"must be in [0, 1.5 x rated load = {1.5 * vehicle.rated_load_kg:g}]")
        # the vehicle file's and the env config's range (0.5 itself had passed both and failed here)
        if self.running_resistance is not None and not 0.0 <= self.running_resistance <= 0.5:
            bad("running_resistance", "must be in [0, 0.5]")
        if self.adhesion is not None and not 0.0 < self.adhesion <= 1.0:
            bad("adhesion", "must be in (0, 1]")
        if not 0.0 <= self.wheel_wear_m < 0.5 * vehicle.drive_wheel_radius_m:
            bad("wheel_wear_m", "must be in [0, half the drive-wheel radius)")
        if not 100.0 <= self.physics_hz <= 5000.0:
            bad("physics_hz", "must be in [100, 5000]")
        for name in ("coupler_stiffness_npm", "drive_inertia_kgm2", "max_drive_speed_mps", "rail_friction",
                     "solver_iterations"):
            if getattr(self, name) <= 0:
                bad(name, "must be > 0")
        for name in ("anti_sway_damping_ratio", "coupler_damping_nspm", "settle_s"):
            if getattr(self, name) < 0:
                bad(name, "must be >= 0")
        for name in _FROM_VEHICLE:
            if getattr(self, name) is not None and getattr(self, name) <= 0:
                bad(name, "must be > 0")
        if self.hook_mass_kg is not None and self.hook_mass_kg >= 0.2 * vehicle.empty_mass_kg:
            bad("hook_mass_kg", "must be below 20 % of the empty mass")


__all__ = ["PlantConfig", "PlantConfigError"]
