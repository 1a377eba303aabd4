"""The plant's per-tick operations behind one small interface: Chipmunk's own functions, or pymunk's public API.

The plant's tick loop does four things per tick: push the drive force onto the drive section, step the space,
log every body's state into a :class:`pymunk.batch.Buffer`, and read the drive section's velocity; and every
20 ticks it reads the wheels' positions and sets the friction motors' ``max_force``. Through pymunk's public API
each of these creates ``Vec2d`` objects and runs Python-side bookkeeping the plant does not use (post-step
callbacks, deferred adds). Where pymunk's CFFI bindings (the private module ``pymunk._chipmunk``) are reachable,
:func:`tick_ops` and :class:`FrictionMotors` call Chipmunk's C functions directly instead: a 2-3x cheaper tick.

This is the only module that touches pymunk's private internals. Both paths compute the same doubles in the same
order; ``tests/test_plant_paths.py`` checks that a seeded run gives bit-identical logs on both. If a pymunk release
renames the internals, :data:`CHIPMUNK_AVAILABLE` is False and the public path is used.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import pymunk
import pymunk.batch as pbatch

try:
    from pymunk._chipmunk import ffi as _ffi
    from pymunk._chipmunk import lib as _lib

    _lib.cpSpaceStep, _lib.cpSpaceEachBody, _lib.pmSpaceBodyGetIteratorFuncBatched  # noqa: B018
    _lib.cpBodyGetPosition, _lib.cpConstraintSetMaxForce, _lib.cpBodyApplyForceAtLocalPoint  # noqa: B018
    _lib.cpBodyGetVelocity, _lib.cpBodyGetAngle, _lib.cpBodyGetAngularVelocity  # noqa: B018
    CHIPMUNK_AVAILABLE = True
except (ImportError, AttributeError):  # pragma: no cover - other pymunk builds
    _ffi = _lib = None
    CHIPMUNK_AVAILABLE = False

BODY_FIELDS = (
    pbatch.BodyFields.POSITION | pbatch.BodyFields.ANGLE | pbatch.BodyFields.VELOCITY
    | pbatch.BodyFields.ANGULAR_VELOCITY
)
"""What is logged of every body each tick: ``[x, y, angle, vx, vy, w]`` (6 doubles per body)."""


class TickOps(NamedTuple):
    """Per-tick operations as bare callables with their first arguments, called straight from the tick loop.

    The loop calls ``push(body, (f, 0.0), zero)``, ``step(space, dt)``, ``each(space, iterator, data)`` (appends
    all bodies' :data:`BODY_FIELDS` to ``buffer``) and ``velocity(body)``, ``angle(body)``,
    ``angular_velocity(body)`` (the drive section's). ``raw_log`` is the buffer's growing float array (its
    ``.arr`` holds the doubles logged so far) where the loop can read them back, else None.
    """

    push: Callable
    body: Any
    zero: tuple[float, float]
    step: Callable
    space: Any
    each: Callable
    iterator: Any
    data: Any
    velocity: Callable
    angle: Callable
    angular_velocity: Callable
    buffer: pbatch.Buffer
    raw_log: Any


def tick_ops(space: pymunk.Space, drive_body: pymunk.Body, dt_s: float, fast: bool = True) -> TickOps:
    """The tick operations on ``space`` for ``drive_body``: Chipmunk's functions when ``fast`` and available,
    else wrappers of pymunk's public API with the same signatures and identical results."""
    buf = pbatch.Buffer()
    if fast and CHIPMUNK_AVAILABLE:
        lib = _lib
        data = _ffi.new("pmBatchedData *")
        data.fields = BODY_FIELDS.value
        data.floatArray = buf._float_arr
        data.intArray = buf._int_arr
        it = _ffi.addressof(lib, "pmSpaceBodyGetIteratorFuncBatched")
        return TickOps(
            lib.cpBodyApplyForceAtLocalPoint, drive_body._body, (0.0, 0.0), lib.cpSpaceStep, space._space,
            lib.cpSpaceEachBody, it, data, lib.cpBodyGetVelocity, lib.cpBodyGetAngle, lib.cpBodyGetAngularVelocity,
            buf, buf._float_arr,
        )
    d = drive_body

    def push(_body: Any, force: tuple[float, float], point: tuple[float, float]) -> None:
        d.apply_force_at_local_point(force, point)

    def step(_space: Any, _dt: float) -> None:
        space.step(dt_s)

    def each(_space: Any, _it: Any, _data: Any) -> None:
        pbatch.get_space_bodies(space, BODY_FIELDS, buf)

    return TickOps(
        push, None, (0.0, 0.0), step, None, each, None, None, lambda _b: d.velocity, lambda _b: d.angle,
        lambda _b: d.angular_velocity, buf, None,
    )


class FrictionMotors:
    """The wheels' x positions and the friction motors' ``max_force``, through Chipmunk or the public API.

    Parameters
    ----------
    wheels : sequence of pymunk.Body
    motors : sequence of pymunk.SimpleMotor
        One per wheel.
    fast : bool
        Use Chipmunk's functions when available.
    """

    def __init__(self, wheels: Sequence[pymunk.Body], motors: Sequence[pymunk.SimpleMotor], fast: bool = True):
        self.wheels = list(wheels)
        self.motors = list(motors)
        self.fast = bool(fast and CHIPMUNK_AVAILABLE)
        self._wheel_c = [w._body for w in self.wheels] if self.fast else []
        self._motor_c = [m._constraint for m in self.motors] if self.fast else []

    def wheel_x_m(self) -> list[float]:
        """x of each wheel's centre."""
        if self.fast:
            get_pos = _lib.cpBodyGetPosition
            return [get_pos(w).x for w in self._wheel_c]
        return [w.position.x for w in self.wheels]

    def set_max_forces(self, values: Sequence[float]) -> None:
        """Set each motor's ``max_force`` (the friction torque it can hold)."""
        if self.fast:
            set_max = _lib.cpConstraintSetMaxForce
            for m, value in zip(self._motor_c, values):
                set_max(m, value)
        else:
            for m, value in zip(self.motors, values):
                m.max_force = value


__all__ = ["BODY_FIELDS", "CHIPMUNK_AVAILABLE", "FrictionMotors", "TickOps", "tick_ops"]
