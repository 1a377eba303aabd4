"""Energy books of the plant: traction work and the work dissipated by running resistance, brakes and dampers.

They close the energy balance ``traction work = dE_mech + friction + dampers`` (``tests/test_plant.py``,
``scripts/bench_plant.py --checks``). Each tick's work is taken with mid-point velocities (the average of before and
after the step). Kept only with ``PlantConfig(track_energy=True)``: it costs about twice the per-tick time.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import pymunk

from uuom_core.vehicle import G_MPS2


def _spring_rate_mps(sp: pymunk.DampedSpring) -> float:
    """Rate of change of a damped spring's length (m/s)."""
    a, b = sp.a, sp.b
    pa = a.local_to_world(sp.anchor_a)
    pb = b.local_to_world(sp.anchor_b)
    n = (pb - pa).normalized()
    return (b.velocity_at_world_point(pb) - a.velocity_at_world_point(pa)).dot(n)


class EnergyBooks:
    """Running totals (J) of the work done on the train, tick by tick.

    Parameters
    ----------
    drive_body : pymunk.Body
        The body the traction force acts on (its along-body velocity times the force is the traction power).
    friction_motors : sequence of pymunk.SimpleMotor
        The Coulomb-friction motors of resistance and brakes (their impulse times the relative rate is work).
    dampers : sequence of pymunk.DampedSpring
        The viscous dampers (coupler, anti-sway damper).
    dt_s : float
        Physics tick.

    Attributes
    ----------
    totals : dict
        ``traction_work_j``, ``friction_j``, ``damper_j``.
    """

    def __init__(self, drive_body: pymunk.Body, friction_motors: Sequence[pymunk.SimpleMotor],
                 dampers: Sequence[pymunk.DampedSpring], dt_s: float) -> None:
        self.drive_body = drive_body
        self.friction_motors = list(friction_motors)
        self.dampers = list(dampers)
        self.dt_s = dt_s
        self.totals = {"traction_work_j": 0.0, "friction_j": 0.0, "damper_j": 0.0}

    def before_step(self) -> tuple[float, list[float]]:
        """The velocities the tick's work is taken with (call before the physics step, pass to :meth:`add_tick`)."""
        d = self.drive_body
        ang = d.angle
        vx, vy = d.velocity
        rel = [m.a.angular_velocity - m.b.angular_velocity for m in self.friction_motors]
        return vx * math.cos(ang) + vy * math.sin(ang), rel

    def add_tick(self, force_n: float, before: tuple[float, list[float]]) -> None:
        """Book the work of the tick just stepped, with traction force ``force_n``."""
        dt = self.dt_s
        e = self.totals
        v_pre, rel_pre = before
        v_post, rel_post = self.before_step()
        e["traction_work_j"] += force_n * 0.5 * (v_pre + v_post) * dt
        for m, r0, r1 in zip(self.friction_motors, rel_pre, rel_post):
            e["friction_j"] += abs(m.impulse * 0.5 * (r0 + r1))
        for sp in self.dampers:
            e["damper_j"] += sp.damping * _spring_rate_mps(sp) ** 2 * dt


def mechanical_energy_j(space: pymunk.Space, coupler: pymunk.DampedSpring) -> float:
    """Kinetic (translation and rotation of every body) + gravitational + coupler-spring energy (J)."""
    total = 0.0
    for b in space.bodies:
        vx, vy = b.velocity
        total += 0.5 * b.mass * (vx * vx + vy * vy) + 0.5 * b.moment * b.angular_velocity**2
        total += b.mass * G_MPS2 * b.position.y
    sp = coupler
    dist = (sp.b.local_to_world(sp.anchor_b) - sp.a.local_to_world(sp.anchor_a)).length
    total += 0.5 * sp.stiffness * (dist - sp.rest_length) ** 2
    return total


def centre_of_mass_speed_mps(space: pymunk.Space) -> float:
    """Horizontal speed of the centre of mass of all bodies (the momentum: free of the load-sway exchange)."""
    bodies = space.bodies
    return sum(b.mass * b.velocity.x for b in bodies) / sum(b.mass for b in bodies)


__all__ = ["EnergyBooks", "centre_of_mass_speed_mps", "mechanical_energy_j"]
