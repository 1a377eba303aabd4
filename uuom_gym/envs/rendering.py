"""Rendering of ``UUOM-Track-v0`` with pygame: a side view of the roadway and the train with its swinging load,
a speed gauge against the true and the estimated speed limit, and estimated vs true mass and slope.

Headless-safe: frames are drawn on an off-screen surface, and ``render_mode="human"`` falls back to SDL's dummy
video driver when there is no display (``DISPLAY`` / ``WAYLAND_DISPLAY`` unset on Linux).
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass

import numpy as np

_BG = (24, 26, 32)
_ROCK = (62, 58, 52)
_RAIL = (200, 200, 210)
_TRAIN = (235, 170, 40)
_LOAD = (120, 160, 220)
_CHAIN = (170, 170, 170)
_TEXT = (235, 235, 235)
_GOOD = (80, 200, 120)
_BAD = (230, 70, 60)
_EST = (90, 170, 255)
_STATION = (80, 220, 220)


@dataclass
class Frame:
    """Everything one frame shows (built by the environment from its true and estimated state)."""

    track_s_m: np.ndarray
    track_elevation_m: np.ndarray
    track_length_m: float
    position_m: float
    sway_rad: float
    speed_mps: float
    true_limit_mps: float
    est_limit_mps: float
    true_mass_kg: float
    est_mass_kg: float
    mass_std_kg: float
    true_slope_rad: float
    est_slope_rad: float
    slope_std_rad: float
    command: float
    t_s: float
    cost: float
    observer: str
    train_length_m: float
    violations: tuple[str, ...] = ()


def _ensure_video_driver(human: bool) -> None:
    if not human:
        return
    headless = sys.platform.startswith("linux") and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    )
    if headless:
        os.environ.setdefault("SDL_VIDEODRIVER", "dummy")


class Renderer:
    """Draws :class:`Frame` objects; ``mode`` is ``"rgb_array"`` or ``"human"``.

    Parameters
    ----------
    mode : str
        ``"rgb_array"`` (return frames) or ``"human"`` (show them in a window at ``fps``).
    size : (int, int)
        Frame width and height in pixels.
    window_m : float
        Length of track shown around the train.
    fps : int
        Display rate for ``"human"``.
    """

    def __init__(self, mode: str, size: tuple[int, int] = (800, 450), window_m: float = 60.0, fps: int = 30) -> None:
        if mode not in ("rgb_array", "human"):
            raise ValueError(f"render mode must be 'rgb_array' or 'human', got {mode!r}")
        _ensure_video_driver(mode == "human")
        os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
        import pygame

        self._pg = pygame
        self.mode = mode
        self.size = (int(size[0]), int(size[1]))
        self.window_m = float(window_m)
        self.fps = int(fps)
        pygame.font.init()
        self._font = pygame.font.Font(None, max(14, self.size[1] // 24))
        self._big = pygame.font.Font(None, max(18, self.size[1] // 16))
        self._surface = pygame.Surface(self.size)
        self._screen = None
        self._clock = None

    # ----------------------------------------------------------------------------------------------------------
    def draw(self, f: Frame) -> np.ndarray | None:
        """Draw one frame; return it as an ``(H, W, 3)`` uint8 array (``rgb_array``) or show it (``human``)."""
        pg = self._pg
        surf = self._surface
        w, h = self.size
        surf.fill(_BG)
        self._draw_side_view(surf, f, pg.Rect(0, 0, w, int(h * 0.62)))
        self._draw_gauge(surf, f, pg.Rect(16, int(h * 0.66), int(w * 0.46), int(h * 0.30)))
        self._draw_panel(surf, f, pg.Rect(int(w * 0.52), int(h * 0.66), int(w * 0.46), int(h * 0.30)))
        if self.mode == "human":
            if self._screen is None:
                pg.display.init()
                self._screen = pg.display.set_mode(self.size)
                pg.display.set_caption("UUOM-Track-v0")
                self._clock = pg.time.Clock()
            pg.event.pump()
            self._screen.blit(surf, (0, 0))
            pg.display.flip()
            self._clock.tick(self.fps)
            return None
        return np.transpose(np.array(pg.surfarray.pixels3d(surf), dtype=np.uint8), (1, 0, 2)).copy()

    def close(self) -> None:
        if self._screen is not None:
            self._pg.display.quit()
            self._screen = None

    # ----------------------------------------------------------------------------------------------------------
    def _draw_side_view(self, surf, f: Frame, rect) -> None:
        pg = self._pg
        half = self.window_m / 2
        s0, s1 = f.position_m - half, f.position_m + half
        s = np.linspace(s0, s1, 121)
        z = np.interp(s, f.track_s_m, f.track_elevation_m)
        z_train = float(np.interp(f.position_m, f.track_s_m, f.track_elevation_m))
        # Vertical exaggeration 1: a 15 deg grade must look like one.
        scale = rect.width / self.window_m
        rail_y = rect.top + rect.height * 0.30

        def to_px(si: float, zi: float) -> tuple[int, int]:
            return int(rect.left + (si - s0) * scale), int(rail_y - (zi - z_train) * scale)

        pts = [to_px(si, zi) for si, zi in zip(s, z)]
        roof = pts + [(rect.right, rect.top), (rect.left, rect.top)]
        pg.draw.polygon(surf, _ROCK, roof)
        # roadway floor 4.5 m below the rail (the roadway follows the grade)
        floor = [(x, y + int(4.5 * scale)) for x, y in pts]
        pg.draw.polygon(surf, _ROCK, floor + [(rect.right, rect.bottom), (rect.left, rect.bottom)])
        pg.draw.lines(surf, _RAIL, False, pts, 3)
        for station in (0.0, f.track_length_m):
            if s0 <= station <= s1:
                x, y = to_px(station, float(np.interp(station, f.track_s_m, f.track_elevation_m)))
                pg.draw.line(surf, _STATION, (x, y), (x, y + int(rect.height * 0.6)), 3)
        # The train: body hanging below the rail along its length, load on chains from its middle.
        n_cars = 5
        car_len = f.train_length_m / n_cars
        for i in range(n_cars):
            a = f.position_m - f.train_length_m / 2 + i * car_len
            b = a + car_len * 0.9
            za = float(np.interp(a, f.track_s_m, f.track_elevation_m))
            zb = float(np.interp(b, f.track_s_m, f.track_elevation_m))
            pa, pb = to_px(a, za), to_px(b, zb)
            drop = int(0.9 * scale)
            pg.draw.polygon(surf, _TRAIN, [pa, pb, (pb[0], pb[1] + drop), (pa[0], pa[1] + drop)])
        cx, cy = to_px(f.position_m, z_train)
        cy += int(0.9 * scale)
        chain = 2.2 * scale
        lx = cx + int(chain * math.sin(f.sway_rad))
        ly = cy + int(chain * math.cos(f.sway_rad))
        pg.draw.line(surf, _CHAIN, (cx - int(scale), cy), (lx - int(scale), ly), 2)
        pg.draw.line(surf, _CHAIN, (cx + int(scale), cy), (lx + int(scale), ly), 2)
        load_w = int(max(2.0, 3.0 * scale))
        load_h = int(max(2.0, 1.2 * scale * (0.3 + f.true_mass_kg / 36_000.0)))
        pg.draw.rect(surf, _LOAD, pg.Rect(lx - load_w // 2, ly, load_w, load_h))
        label = self._font.render(
            f"slope {math.degrees(f.true_slope_rad):+5.1f} deg   s = {f.position_m:7.1f} m of "
            f"{f.track_length_m:.0f} m   t = {f.t_s:6.1f} s   sway {math.degrees(f.sway_rad):+5.1f} deg",
            True,
            _TEXT,
        )
        surf.blit(label, (rect.left + 8, rect.bottom - label.get_height() - 4))

    def _draw_gauge(self, surf, f: Frame, rect) -> None:
        pg = self._pg
        vmax = 2.5
        bar = pg.Rect(rect.left, rect.top + rect.height // 3, rect.width - 10, rect.height // 4)
        pg.draw.rect(surf, (50, 50, 60), bar)
        frac = min(max(f.speed_mps / vmax, 0.0), 1.0)
        color = _GOOD if f.speed_mps <= f.true_limit_mps else _BAD
        pg.draw.rect(surf, color, pg.Rect(bar.left, bar.top, int(bar.width * frac), bar.height))
        for lim, col, name in ((f.true_limit_mps, _TEXT, "true"), (f.est_limit_mps, _EST, "est")):
            x = bar.left + int(bar.width * min(max(lim / vmax, 0.0), 1.0))
            pg.draw.line(surf, col, (x, bar.top - 8), (x, bar.bottom + 8), 3)
            t = self._font.render(name, True, col)
            surf.blit(t, (x - t.get_width() // 2, bar.bottom + 8 if name == "true" else bar.top - 8 - t.get_height()))
        title = self._big.render(
            f"speed {f.speed_mps:4.2f} m/s  limit {f.true_limit_mps:4.2f} (est {f.est_limit_mps:4.2f})", True, _TEXT
        )
        surf.blit(title, (rect.left, rect.top))
        cmd = self._font.render(f"command {f.command:+.2f}   cost {f.cost:.3f}", True, _TEXT)
        surf.blit(cmd, (rect.left, rect.bottom - cmd.get_height()))

    def _draw_panel(self, surf, f: Frame, rect) -> None:
        lines = [
            (f"observer: {f.observer}", _TEXT),
            (
                f"mass  true {f.true_mass_kg / 1000:5.1f} t   est {f.est_mass_kg / 1000:5.1f}"
                f" +- {f.mass_std_kg / 1000:4.1f} t",
                _EST,
            ),
            (
                f"slope true {math.degrees(f.true_slope_rad):+5.1f} deg  est {math.degrees(f.est_slope_rad):+5.1f}"
                f" +- {math.degrees(f.slope_std_rad):3.1f} deg",
                _EST,
            ),
            (("breach: " + ", ".join(f.violations)) if f.violations else "safe", _BAD if f.violations else _GOOD),
        ]
        y = rect.top
        for text, col in lines:
            t = self._font.render(text, True, col)
            self._surface.blit(t, (rect.left, y))
            y += t.get_height() + 6


__all__ = ["Frame", "Renderer"]
