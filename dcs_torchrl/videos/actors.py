"""Moving foreground objects of the embedded clips: animals, people, vehicles, birds, balls, boats.

An actor is a random body plan; ``pose(phase)`` returns its shaded parts at a point of
its gait cycle (phase in cycles), in units where the actor is about 1 tall, its feet at
y = 0 and facing +x. Angles are half-angle tangents (see ``procedural.rotation``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dcs_torchrl.videos.procedural import F32, Part, hsv, rotation, uniform, wave

BLACK = np.zeros(3, F32)


def shadow(length: float) -> Part:
    return Part(0.0, 0.0, length, 0.05 + 0.04 * length, BLACK, shade=0.0, alpha=0.35)


def limb(x: float, y: float, length: float, width: float, swing: float, color) -> Part:
    """A limb hanging from (x, y), turned by the half-angle tangent ``swing``."""
    c, s = rotation(swing)
    return Part(x - s * length / 2, y + c * length / 2, width, length / 2, color, c, s, shade=0.6)


def segment(x0: float, y0: float, x1: float, y1: float, width: float, color, shade: float = 0.6) -> Part:
    """An ellipse from (x0, y0) to (x1, y1)."""
    dx, dy = x1 - x0, y1 - y0
    half = float(np.sqrt(dx * dx + dy * dy)) / 2
    return Part((x0 + x1) / 2, (y0 + y1) / 2, width, half, color, dy / (2 * half), -dx / (2 * half), shade=shade)


def fur(rng) -> np.ndarray:
    tone = int(rng.integers(5))
    return [hsv(uniform(rng, 0.05, 0.1), uniform(rng, 0.4, 0.7), uniform(rng, 0.3, 0.6)),  # brown
            hsv(0.08, 0.1, uniform(rng, 0.12, 0.22)),  # black
            hsv(0.12, uniform(rng, 0.05, 0.15), uniform(rng, 0.8, 0.95)),  # white
            hsv(0.1, uniform(rng, 0.05, 0.15), uniform(rng, 0.45, 0.65)),  # grey
            hsv(uniform(rng, 0.09, 0.12), uniform(rng, 0.5, 0.7), uniform(rng, 0.65, 0.85))][tone]  # golden


@dataclass
class Actor:
    """A body plan; ``pose(phase)`` gives its parts. ``where`` is "ground", "sky" or "water"."""

    kind: str
    where: str
    speed: float  # typical speed in own heights per second
    stride: float  # gait cycles per own height travelled
    params: dict = field(default_factory=dict)

    def pose(self, phase: float) -> list[Part]:
        return POSES[self.kind](self.params, phase)


def quadruped(rng) -> Actor:
    length = uniform(rng, 0.9, 1.6)
    leg = uniform(rng, 0.3, 0.55)
    body = uniform(rng, 0.2, 0.32)
    color = fur(rng)
    params = dict(length=length, leg=leg, body=body, color=color, dark=color * F32(0.75),
                  head=uniform(rng, 0.12, 0.2), neck=uniform(rng, 0.0, 0.25), gait=uniform(rng, 0.15, 0.3))
    return Actor("quadruped", "ground", uniform(rng, 0.5, 2.5), 0.8 / length, params)


def pose_quadruped(p, phase):
    L, leg, body, g = p["length"], p["leg"], p["body"], p["gait"]
    hip_y = -leg
    bob = 0.02 * float(wave(2 * phase))
    hips = (-0.35 * L, 0.35 * L)
    parts = [shadow(0.55 * L)]
    for i, x in enumerate(hips):  # far legs, darker, half a cycle apart from the near ones
        parts.append(limb(x, hip_y, leg + 0.05, 0.06, g * float(wave(phase + 0.5 + 0.25 * i)), p["dark"]))
    parts.append(limb(-0.48 * L, hip_y - body * 0.8, 0.3, 0.035, 0.5 + 0.1 * float(wave(phase)), p["dark"]))  # tail
    parts.append(Part(0.0, hip_y - body * 0.55 + bob, 0.5 * L, body, p["color"]))
    head_x, head_y = 0.5 * L + 0.05, hip_y - body * 0.9 - p["neck"] + bob + 0.02 * float(wave(phase))
    parts.append(segment(0.36 * L, hip_y - body * 0.55 + bob, head_x - 0.03, head_y, body * 0.55, p["color"]))
    parts.append(Part(head_x + 0.05, head_y, p["head"] * 1.3, p["head"], p["color"], *rotation(0.25)))
    parts.append(Part(head_x - 0.06, head_y - p["head"] * 0.9, 0.04, 0.07, p["dark"]))
    for i, x in enumerate(hips):
        parts.append(limb(x + 0.05, hip_y, leg + 0.05, 0.065, g * float(wave(phase + 0.25 * i)), p["color"]))
    return parts


def person(rng) -> Actor:
    skin = hsv(uniform(rng, 0.04, 0.09), uniform(rng, 0.3, 0.6), uniform(rng, 0.3, 0.9))
    shirt = hsv(uniform(rng, 0, 1), uniform(rng, 0.2, 0.9), uniform(rng, 0.2, 0.95))
    trousers = hsv(uniform(rng, 0.55, 0.7) if rng.random() < 0.6 else uniform(rng, 0, 1), uniform(rng, 0.1, 0.6),
                   uniform(rng, 0.15, 0.6))
    hair = hsv(uniform(rng, 0.05, 0.12), uniform(rng, 0.2, 0.7), uniform(rng, 0.08, 0.6))
    running = rng.random() < 0.4
    params = dict(skin=skin, shirt=shirt, trousers=trousers, hair=hair, swing=0.45 if running else 0.25,
                  width=uniform(rng, 0.09, 0.14))
    return Actor("person", "ground", uniform(rng, 1.5, 3.5) if running else uniform(rng, 0.5, 1.2), 1.0, params)


def pose_person(p, phase):
    a, w = p["swing"], p["width"]
    bob = 0.015 * float(wave(2 * phase))
    parts = [Part(0.0, 0.0, 0.32, 0.045, p["board"], shade=0.6)] if "board" in p else [shadow(0.22)]
    parts.append(limb(-0.02, -0.48 + bob, 0.5, 0.045, a * float(wave(phase + 0.5)), p["trousers"] * F32(0.8)))
    parts.append(limb(0.0, -0.72 + bob, 0.33, 0.035, -a * float(wave(phase + 0.5)), p["shirt"] * F32(0.8)))
    parts.append(Part(0.0, -0.66 + bob, w, 0.2, p["shirt"]))
    parts.append(Part(0.0, -0.91 + bob, 0.075, 0.085, p["skin"]))
    parts.append(Part(-0.015, -0.95 + bob, 0.07, 0.05, p["hair"], shade=0.5))
    parts.append(limb(0.02, -0.48 + bob, 0.5, 0.05, a * float(wave(phase)), p["trousers"]))
    parts.append(limb(0.0, -0.72 + bob, 0.33, 0.04, -a * float(wave(phase)), p["shirt"]))
    return parts


def vehicle(rng) -> Actor:
    paint = hsv(uniform(rng, 0, 1), uniform(rng, 0.0, 0.9), uniform(rng, 0.2, 0.95))
    params = dict(paint=paint, length=uniform(rng, 1.6, 3.2), cabin=uniform(rng, 0.3, 0.6),
                  glass=hsv(uniform(rng, 0.5, 0.65), 0.3, uniform(rng, 0.15, 0.4)))
    return Actor("vehicle", "ground", uniform(rng, 3.0, 8.0), 1.5, params)


def pose_vehicle(p, phase):
    L, cabin = p["length"], p["cabin"]
    bump = 0.01 * float(wave(phase * 3))
    wheel = 0.17
    parts = [shadow(0.52 * L)]
    roof = -0.55 - cabin * 0.3 + bump
    parts.append(Part(-0.05 * L, roof, 0.28 * L, 0.18 + cabin * 0.2, p["paint"], box=True, shade=0.5))
    parts.append(Part(-0.05 * L, roof, 0.24 * L, 0.12 + cabin * 0.15, p["glass"], box=True, shade=0.3))
    parts.append(Part(0.0, -0.35 + bump, 0.5 * L, 0.18, p["paint"], box=True, shade=0.5))
    for x in (-0.32 * L, 0.32 * L):
        parts.append(Part(x, -wheel, wheel, wheel, hsv(0, 0, 0.1), shade=0.4))
        parts.append(Part(x, -wheel, wheel * 0.45, wheel * 0.45, hsv(0, 0, 0.6), shade=0.4))
    return parts


def bird(rng) -> Actor:
    color = hsv(uniform(rng, 0, 0.15), uniform(rng, 0.0, 0.4), uniform(rng, 0.1, 0.95))
    params = dict(color=color, span=uniform(rng, 0.7, 1.2))
    return Actor("bird", "sky", uniform(rng, 2.0, 5.0), 0.6, params)


def pose_bird(p, phase):
    flap = 0.7 * float(wave(phase))
    span, color = p["span"], p["color"]
    wing_far = limb(-0.05, -0.5, span * 0.55, 0.08, 1.6 + flap, color * F32(0.7))
    wing_near = limb(0.0, -0.5, span * 0.6, 0.09, 1.6 - flap * 0.1 + flap, color)
    return [wing_far, Part(0.0, -0.5, 0.35, 0.1, color), Part(0.33, -0.55, 0.08, 0.07, color), wing_near]


def ball(rng) -> Actor:
    color = hsv(uniform(rng, 0, 1), uniform(rng, 0.0, 0.9), uniform(rng, 0.5, 1.0))
    return Actor("ball", "ground", uniform(rng, 1.0, 4.0), 0.5, dict(color=color, bounce=uniform(rng, 0.5, 2.0)))


def pose_ball(p, phase):
    height = p["bounce"] * (1.0 - float(wave(phase)) ** 2)
    return [shadow(0.2), Part(0.0, -0.2 - height, 0.2, 0.2, p["color"], shade=0.9)]


def boat(rng) -> Actor:
    hull = hsv(uniform(rng, 0, 1), uniform(rng, 0.0, 0.8), uniform(rng, 0.3, 0.95))
    params = dict(hull=hull, length=uniform(rng, 1.5, 3.0), sail=rng.random() < 0.5)
    return Actor("boat", "water", uniform(rng, 0.5, 2.0), 0.3, params)


def pose_boat(p, phase):
    L, roll = p["length"], 0.01 * float(wave(phase))
    parts = [Part(0.0, -0.05 + roll, 0.5 * L, 0.16, p["hull"], box=True, shade=0.5)]
    if p["sail"]:
        parts.insert(0, Part(0.05 * L, -0.75, 0.02, 0.6, hsv(0, 0, 0.3), box=True))
        parts.insert(1, Part(-0.05, -0.75 + roll, 0.2, 0.55, hsv(0.1, 0.05, 0.95), *rotation(0.06), shade=0.4))
    else:
        parts.insert(0, Part(-0.1 * L, -0.3 + roll, 0.2 * L, 0.15, hsv(0, 0, 0.9), box=True, shade=0.4))
    parts.append(Part(0.0, 0.05, 0.55 * L, 0.04, hsv(0.55, 0.1, 0.95), alpha=0.5, shade=0.0))  # wake
    return parts


POSES = {
    "quadruped": pose_quadruped,
    "person": pose_person,
    "vehicle": pose_vehicle,
    "bird": pose_bird,
    "ball": pose_ball,
    "boat": pose_boat,
}
MAKERS = {"quadruped": quadruped, "person": person, "vehicle": vehicle, "bird": bird, "ball": ball, "boat": boat}

# Which actors each scene may hold: (main subjects, extras).
CAST = {
    "meadow": (("quadruped", "person", "vehicle"), ("quadruped", "person", "bird", "ball")),
    "coast": (("boat", "person"), ("boat", "bird")),
    "forest": (("person", "quadruped"), ("person", "quadruped", "bird")),
    "city": (("vehicle", "person"), ("vehicle", "person", "bird")),
    "arena": (("person",), ("person", "ball")),
}


def mirrored(parts: list[Part]) -> list[Part]:
    """The parts facing -x instead of +x."""
    return [Part(-p.x, p.y, p.rx, p.ry, p.color, p.cos, -p.sin, p.shade, p.alpha, p.box) for p in parts]
