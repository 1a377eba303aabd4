"""Construction of the plant's pymunk space: the rail, the train's bodies and their joints.

Bodies (all in the vertical plane of the track, x forward, y up), with the geometry of
:class:`uuom_core.vehicle.VehicleParams`:

* the rail: static pymunk segments along the track's polyline (:meth:`TrackProfile.polyline`), with buffer stops
  at both ends;
* four carrying wheels (circles of the carrying-wheel radius, moment ``inertia_wheel_count * J / 4`` each, so the
  rotating-mass term ``m_rot = n_w J / r_carry**2`` of the estimator model is physically present) rolling on the
  rail by contact friction;
* the *drive section* (front cab, drive units, brake car) hanging from the front two wheels by pivots, so it
  pitches with the rail;
* the *lifting-beam section* (lifting beams and rear cab) hanging from the rear two wheels, joined to the drive
  section by a compliant coupler (:class:`pymunk.DampedSpring` along the track);
* the *load* (hook block + payload) hanging from the lifting beam on two parallel chains (:class:`pymunk.PinJoint`
  of ``chain_length_m``) - a parallelogram, so the load swings without turning - with an anti-sway damper (a
  zero-stiffness :class:`pymunk.DampedSpring`) along the track;
* Coulomb friction on each carrying wheel's rotation (:class:`pymunk.SimpleMotor` with rate 0; the plant sets its
  ``max_force`` to the running resistance plus the brake force).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymunk
import pymunk.batch as pbatch

from uuom_core.vehicle import G_MPS2, VehicleParams
from uuom_gym.sim.plant_config import PlantConfig
from uuom_gym.sim.track import TrackProfile

# The anti-sway damper's line runs from a point this far behind the beam (body x) to the load, so it is
# (nearly) along the track whatever the swing angle.
_SWAY_DAMPER_ANCHOR_M = -30.0


@dataclass
class TrainBodies:
    """The pymunk space of one plant and handles to what the plant drives and reads.

    Attributes
    ----------
    space : pymunk.Space
    wheels : list of pymunk.Body
        Carrying wheels: front and rear of the drive section, front and rear of the lifting-beam section.
    drive_body, beam_body, load_body : pymunk.Body
    coupler, sway_damper : pymunk.DampedSpring
    sway_damping_nspm : float
        Damping coefficient of the anti-sway damper.
    friction_motors : list of pymunk.SimpleMotor
        Resistance/brake friction of each wheel, in wheel order.
    masses : dict
        ``drive``, ``beam``, ``load`` (hook + payload), ``wheels`` (all four), kg.
    wheel_weight_kg : list of float
        Static weight each wheel carries (for the resistance ``mu N``): half a section each, the load on the beam.
    chain_top, chain_bottom : list of tuple
        The chains' ends in beam and in load coordinates (rear chain, front chain).
    n_bodies : int
        Number of bodies in the batch buffer (the static rail body included).
    index : dict
        Position of ``drive``, ``beam``, ``load`` and ``w0`` (front wheel) in the batch buffer.
    body_mass_share : ndarray
        Each batch-buffer body's share of the total mass (0 for the rail).
    """

    space: pymunk.Space
    wheels: list
    drive_body: pymunk.Body
    beam_body: pymunk.Body
    load_body: pymunk.Body
    coupler: pymunk.DampedSpring
    sway_damper: pymunk.DampedSpring
    sway_damping_nspm: float
    friction_motors: list
    masses: dict
    wheel_weight_kg: list
    chain_top: list
    chain_bottom: list
    n_bodies: int
    index: dict
    body_mass_share: np.ndarray



LOAD_RATIO_REF = 5.0
"""The hanging load over the lighter section up to which ``PlantConfig.solver_iterations`` suffice (the project's
vehicle: 3.0 at rated load, 4.5 at 1.5x)."""


def solver_iterations_for(base: int, load_kg: float, lighter_section_kg: float) -> int:
    """pymunk solver iterations for a train whose load is ``load_kg`` and whose lighter section is
    ``lighter_section_kg``: ``base`` up to :data:`LOAD_RATIO_REF`, then in proportion.

    Why: the solver resolves the chain load - beam - coupler - drive section iteratively, and the heavier the load
    against the sections the more iterations it needs. With 20 a 16 t train carrying 34 t (ratio 8.3) had its drive
    section's speed ring at 0.13 m/s under a light brake (0.005 m/s with 30), and the oracle controller tripped on it;
    with more physics ticks per second the ring vanished as well (docs/robustness.md, session 59).
    """
    ratio = load_kg / max(lighter_section_kg, 1.0)
    return int(base) if ratio <= LOAD_RATIO_REF else int(math.ceil(base * ratio / LOAD_RATIO_REF))

def _rail(space: pymunk.Space, track: TrackProfile) -> None:
    pts = track.polyline()
    segs = []
    for i in range(len(pts) - 1):
        seg = pymunk.Segment(space.static_body, tuple(pts[i]), tuple(pts[i + 1]), 0.0)
        seg.friction = 1.0
        segs.append(seg)
    for i, seg in enumerate(segs):
        # neighbours stop wheels from catching on the vertices between segments
        prev = tuple(pts[i - 1]) if i > 0 else tuple(pts[i])
        nxt = tuple(pts[i + 2]) if i + 2 < len(pts) else tuple(pts[i + 1])
        seg.set_neighbors(prev, nxt)
    # buffer stops at both ends of the rail (40 m beyond the track): a train driven off the end stops there
    # instead of falling
    for x, z in (pts[0], pts[-1]):
        stop = pymunk.Segment(space.static_body, (x, z - 0.2), (x, z + 1.0), 0.05)
        stop.friction = 0.0
        segs.append(stop)
    space.add(*segs)


def _rail_point(track: TrackProfile, s: float) -> tuple[float, float, float]:
    th = track.slope_at(s)
    return float(track.x_at(s)), float(track.elevation_at(s)), float(th)


def build_train(vehicle: VehicleParams, config: PlantConfig, track: TrackProfile, start_s_m: float) -> TrainBodies:
    """Build the space with the train at rest on the rail, its reference point at arc length ``start_s_m``.

    ``config`` must be resolved (:meth:`PlantConfig.resolved`): its chain length and hook mass are used.
    """
    v, c = vehicle, config
    space = pymunk.Space()
    space.gravity = (0.0, -G_MPS2)
    # iterations set after the masses are known (solver_iterations_for)
    # Allowed wheel/rail overlap. Chipmunk's default (0.1 length units) would be 10 cm in metres; with much
    # less than 1 mm the wheels lose contact for a tick at every convex polyline vertex (the rail drops away by
    # v * turn * dt) and land with a knock that shows as +-1 m/s^2 accelerometer spikes.
    space.collision_slop = 1e-3
    _rail(space, track)

    d_len, d_hang, d_half = v.drive_section_length_m, v.drive_hang_m, v.drive_wheel_base_m / 2
    l_len, l_hang, l_half = v.beam_section_length_m, v.beam_hang_m, v.beam_wheel_base_m / 2
    wheel_kg = v.carrying_wheel_mass_kg
    load_h, load_len = v.load_block_height_m, v.load_block_length_m
    chain_dx = v.chain_spacing_m / 2
    r_c = v.carrying_wheel_radius_m
    j_w = v.inertia_wheel_count * v.wheel_inertia_kgm2 / 4.0
    hook = c.hook_mass_kg
    body_mass = v.empty_mass_kg - 4 * wheel_kg - hook
    m_d = v.drive_section_mass_share * body_mass
    m_l = body_mass - m_d
    m_p = hook + c.load_kg
    masses = {"drive": m_d, "beam": m_l, "load": m_p, "wheels": 4 * wheel_kg}
    space.iterations = solver_iterations_for(c.solver_iterations, m_p, min(m_d, m_l))

    s_ref = start_s_m
    s_l = s_ref - d_len / 2 - v.coupler_gap_m - l_len / 2
    wheel_s = [s_ref + d_half, s_ref - d_half, s_l + l_half, s_l - l_half]
    wheels = []
    centres = []
    for s in wheel_s:
        x, z, th = _rail_point(track, s)
        cx, cz = x - r_c * math.sin(th), z + r_c * math.cos(th)
        b = pymunk.Body(wheel_kg, j_w)
        b.position = (cx, cz)
        shape = pymunk.Circle(b, r_c)
        shape.friction = c.rail_friction
        space.add(b, shape)
        wheels.append(b)
        centres.append((cx, cz))

    h2 = v.section_height_m**2

    def section(m: float, length: float, hang: float, ca: tuple, cb: tuple) -> pymunk.Body:
        ang = math.atan2(cb[1] - ca[1], cb[0] - ca[0])
        mx, mz = (ca[0] + cb[0]) / 2, (ca[1] + cb[1]) / 2
        b = pymunk.Body(m, m * (length**2 + h2) / 12.0)
        b.angle = ang
        b.position = (mx + hang * math.sin(ang), mz - hang * math.cos(ang))
        space.add(b)
        return b

    # wheel order along the track: front of drive (0), rear of drive (1), front of beam (2), rear of beam (3)
    d = section(m_d, d_len, d_hang, centres[1], centres[0])
    beam = section(m_l, l_len, l_hang, centres[3], centres[2])
    cons: list[pymunk.Constraint] = []
    for w, b in ((wheels[0], d), (wheels[1], d), (wheels[2], beam), (wheels[3], beam)):
        cons.append(pymunk.PivotJoint(w, b, w.position))
    # coupler: a damped spring between the sections' ends on the pivot lines
    a_d = (-d_len / 2, d_hang)
    a_b = (l_len / 2, l_hang)
    rest = (d.local_to_world(a_d) - beam.local_to_world(a_b)).length
    coupler = pymunk.DampedSpring(d, beam, a_d, a_b, rest, c.coupler_stiffness_npm, c.coupler_damping_nspm)
    cons.append(coupler)
    # load on two parallel chains (parallelogram): hangs plumb, swings without turning
    top = [(-chain_dx, -l_hang), (chain_dx, -l_hang)]
    ang = beam.angle
    ey = (-math.sin(ang), math.cos(ang))
    tw = [beam.local_to_world(p) for p in top]
    mid = ((tw[0][0] + tw[1][0]) / 2, (tw[0][1] + tw[1][1]) / 2)
    load = pymunk.Body(m_p, m_p * (load_len**2 + load_h**2) / 12.0)
    load.angle = ang
    load.position = (mid[0] - ey[0] * load_h / 2, mid[1] - c.chain_length_m - ey[1] * load_h / 2)
    space.add(load)
    bottom = [(-chain_dx, load_h / 2), (chain_dx, load_h / 2)]
    for a, bpt in zip(top, bottom):
        cons.append(pymunk.PinJoint(beam, load, a, bpt))
    # anti-sway damper: a zero-stiffness damped spring whose line runs along the track at the load's height,
    # so it damps the load's along-track motion relative to the beam
    omega_p = math.sqrt(G_MPS2 / c.chain_length_m)
    sway_damping = 2.0 * c.anti_sway_damping_ratio * m_p * omega_p
    far = (_SWAY_DAMPER_ANCHOR_M, -l_hang - c.chain_length_m - load_h / 2)
    far_w = beam.local_to_world(far)
    sway_damper = pymunk.DampedSpring(beam, load, far, (0.0, 0.0), (far_w - load.position).length, 0.0, sway_damping)
    cons.append(sway_damper)
    # resistance + brakes: Coulomb friction on each carrying wheel's rotation relative to its section
    motors = []
    for w, b in ((wheels[0], d), (wheels[1], d), (wheels[2], beam), (wheels[3], beam)):
        m = pymunk.SimpleMotor(w, b, 0.0)
        m.max_force = 0.0
        motors.append(m)
        cons.append(m)
    space.add(*cons)
    mw = wheel_kg
    wheel_weight = [mw + m_d / 2, mw + m_d / 2, mw + (m_l + m_p) / 2, mw + (m_l + m_p) / 2]
    # body order in the batch buffer
    buf = pbatch.Buffer()
    pbatch.get_space_bodies(space, pbatch.BodyFields.BODY_ID, buf)
    ids = list(memoryview(buf.int_buf()).cast("P"))
    by_id = {b.id: b for b in space.bodies}
    batch_masses = np.array([by_id[i].mass if i in by_id else 0.0 for i in ids])  # (the static rail body: 0)
    index = {name: ids.index(b.id) for name, b in (("drive", d), ("beam", beam), ("load", load), ("w0", wheels[0]))}
    return TrainBodies(
        space=space, wheels=wheels, drive_body=d, beam_body=beam, load_body=load, coupler=coupler,
        sway_damper=sway_damper, sway_damping_nspm=sway_damping, friction_motors=motors, masses=masses,
        wheel_weight_kg=wheel_weight, chain_top=top, chain_bottom=bottom, n_bodies=len(ids), index=index,
        body_mass_share=batch_masses / batch_masses.sum(),
    )


__all__ = ["TrainBodies", "build_train"]
