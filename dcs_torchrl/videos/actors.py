"""Moving foreground objects of the embedded clips: animals, people, vehicles, birds, balls, boats.

An actor is a random body plan; ``pose(phase)`` returns its shaded parts at a point of
its gait cycle (phase in cycles), in units where the actor is about 1 tall, its feet at
y = 0 and facing +x. Angles are half-angle tangents (see ``procedural.rotation``).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from dcs_torchrl.videos.procedural import BANDS, CHECKS, F32, SPOTS, STRIPES, Part, hsv, rotation, uniform, wave

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


def vivid(rng, value=(0.5, 1.0)) -> np.ndarray:
    """A saturated colour of any hue (clothes, paint, toys)."""
    return hsv(uniform(rng, 0, 1), uniform(rng, 0.6, 1.0), uniform(rng, *value))


def garment(rng, chance: float = 0.6) -> tuple[int, np.ndarray | None, float]:
    """(pattern, its colour, its frequency) of a piece of clothing or paint, often plain."""
    if rng.random() >= chance:
        return 0, None, 3.0
    return (int((STRIPES, BANDS, CHECKS, SPOTS)[int(rng.integers(4))]), vivid(rng, (0.1, 1.0)),
            uniform(rng, 2.0, 6.0))


def coat(rng) -> tuple[int, np.ndarray | None, float, np.ndarray | None]:
    """An animal's coat: (pattern, its colour, its frequency, a base colour replacing the fur or None)."""
    kind = int(rng.integers(6))
    if kind == 1:  # spotted: dalmatian, leopard, giraffe-ish
        return SPOTS, hsv(0.07, 0.6, uniform(rng, 0.05, 0.25)), uniform(rng, 4.0, 8.0), None
    if kind == 2:  # tiger
        return STRIPES, hsv(0.05, 0.5, 0.08), uniform(rng, 5.0, 9.0), hsv(uniform(rng, 0.05, 0.09), 0.85, 0.9)
    if kind == 3:  # zebra
        return STRIPES, hsv(0.0, 0.0, 0.08), uniform(rng, 6.0, 10.0), hsv(0.1, 0.03, 0.95)
    if kind == 4:  # cow: large patches
        return SPOTS, hsv(0.08, 0.3, 0.1), uniform(rng, 1.5, 2.5), hsv(0.1, 0.04, 0.95)
    return 0, None, 3.0, None  # plain fur


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
    pattern, marks, freq, base = coat(rng)
    color = color if base is None else base
    params = dict(length=length, leg=leg, body=body, color=color, dark=color * F32(0.75),
                  head=uniform(rng, 0.12, 0.2), neck=uniform(rng, 0.0, 0.25), gait=uniform(rng, 0.15, 0.3),
                  coat=dict(pattern=pattern, pattern_color=marks, freq=freq),
                  saddle=vivid(rng) if rng.random() < 0.35 else None)
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
    parts.append(Part(0.0, hip_y - body * 0.55 + bob, 0.5 * L, body, p["color"], **p["coat"]))
    if p["saddle"] is not None:  # a blanket, saddle or harness
        parts.append(Part(-0.02 * L, hip_y - body * 1.1 + bob, 0.2 * L, body * 0.5, p["saddle"], box=True,
                          pattern=BANDS, pattern_color=p["saddle"] * F32(0.3), freq=3.0))
    head_x, head_y = 0.5 * L + 0.05, hip_y - body * 0.9 - p["neck"] + bob + 0.02 * float(wave(phase))
    neck = segment(0.36 * L, hip_y - body * 0.55 + bob, head_x - 0.03, head_y, body * 0.55, p["color"])
    parts.append(replace(neck, **p["coat"]))
    parts.append(Part(head_x + 0.05, head_y, p["head"] * 1.3, p["head"], p["color"], *rotation(0.25)))
    parts.append(Part(head_x - 0.06, head_y - p["head"] * 0.9, 0.04, 0.07, p["dark"]))
    for i, x in enumerate(hips):
        parts.append(limb(x + 0.05, hip_y, leg + 0.05, 0.065, g * float(wave(phase + 0.25 * i)), p["color"]))
    return parts


def person(rng) -> Actor:
    skin = hsv(uniform(rng, 0.04, 0.09), uniform(rng, 0.3, 0.6), uniform(rng, 0.3, 0.9))
    shirt = vivid(rng, (0.35, 1.0))
    trousers = hsv(uniform(rng, 0.55, 0.7) if rng.random() < 0.6 else uniform(rng, 0, 1), uniform(rng, 0.3, 0.9),
                   uniform(rng, 0.15, 0.7))
    hair = hsv(uniform(rng, 0.05, 0.12), uniform(rng, 0.2, 0.7), uniform(rng, 0.08, 0.6))
    running = rng.random() < 0.4
    pattern, marks, freq = garment(rng)
    params = dict(skin=skin, shirt=shirt, trousers=trousers, hair=hair, swing=0.45 if running else 0.25,
                  width=uniform(rng, 0.09, 0.14), print=dict(pattern=pattern, pattern_color=marks, freq=freq),
                  hat=vivid(rng) if rng.random() < 0.4 else None, bag=vivid(rng) if rng.random() < 0.4 else None)
    return Actor("person", "ground", uniform(rng, 1.5, 3.5) if running else uniform(rng, 0.5, 1.2), 1.0, params)


def pose_person(p, phase):
    a, w = p["swing"], p["width"]
    bob = 0.015 * float(wave(2 * phase))
    parts = [Part(0.0, 0.0, 0.32, 0.045, p["board"], shade=0.6)] if "board" in p else [shadow(0.22)]
    parts.append(limb(-0.02, -0.48 + bob, 0.5, 0.045, a * float(wave(phase + 0.5)), p["trousers"] * F32(0.8)))
    parts.append(limb(0.0, -0.72 + bob, 0.33, 0.035, -a * float(wave(phase + 0.5)), p["shirt"] * F32(0.8)))
    if p["bag"] is not None:  # a backpack
        parts.append(Part(-w - 0.03, -0.68 + bob, 0.06, 0.12, p["bag"], box=True, shade=0.5))
    parts.append(Part(0.0, -0.66 + bob, w, 0.2, p["shirt"], **p["print"]))
    parts.append(Part(0.0, -0.91 + bob, 0.075, 0.085, p["skin"]))
    parts.append(Part(-0.015, -0.95 + bob, 0.07, 0.05, p["hair"], shade=0.5))
    if p["hat"] is not None:
        parts.append(Part(0.0, -0.985 + bob, 0.085, 0.035, p["hat"], box=True, shade=0.5))
    parts.append(limb(0.02, -0.48 + bob, 0.5, 0.05, a * float(wave(phase)), p["trousers"]))
    parts.append(limb(0.0, -0.72 + bob, 0.33, 0.04, -a * float(wave(phase)), p["shirt"]))
    return parts


def vehicle(rng) -> Actor:
    paint = vivid(rng, (0.3, 1.0)) if rng.random() < 0.8 else hsv(0, 0, uniform(rng, 0.05, 0.95))
    decal = dict(pattern=BANDS, pattern_color=vivid(rng, (0.1, 1.0)), freq=uniform(rng, 1.5, 3.0)) \
        if rng.random() < 0.5 else {}
    params = dict(paint=paint, length=uniform(rng, 1.6, 3.2), cabin=uniform(rng, 0.3, 0.6), decal=decal,
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
    parts.append(Part(0.0, -0.35 + bump, 0.5 * L, 0.18, p["paint"], box=True, shade=0.5, **p["decal"]))
    parts.append(Part(0.47 * L, -0.4 + bump, 0.03 * L, 0.05, hsv(0.14, 0.5, 1.0), box=True, shade=0.1))  # lamp
    spin = float(wave(phase * 2)) * 0.5
    for x in (-0.32 * L, 0.32 * L):
        parts.append(Part(x, -wheel, wheel, wheel, hsv(0, 0, 0.1), shade=0.4))
        parts.append(Part(x, -wheel, wheel * 0.5, wheel * 0.5, hsv(0, 0, 0.75), *rotation(spin), shade=0.4,
                          pattern=STRIPES, pattern_color=hsv(0, 0, 0.2), freq=3.0))
    return parts


def bird(rng) -> Actor:
    color = hsv(uniform(rng, 0, 0.15), uniform(rng, 0.0, 0.4), uniform(rng, 0.1, 0.95)) if rng.random() < 0.6 \
        else vivid(rng)  # a parrot
    params = dict(color=color, span=uniform(rng, 0.7, 1.2))
    return Actor("bird", "sky", uniform(rng, 2.0, 5.0), 0.6, params)


def pose_bird(p, phase):
    flap = 0.7 * float(wave(phase))
    span, color = p["span"], p["color"]
    wing_far = limb(-0.05, -0.5, span * 0.55, 0.08, 1.6 + flap, color * F32(0.7))
    wing_near = limb(0.0, -0.5, span * 0.6, 0.09, 1.6 - flap * 0.1 + flap, color)
    return [wing_far, Part(0.0, -0.5, 0.35, 0.1, color), Part(0.33, -0.55, 0.08, 0.07, color), wing_near]


def ball(rng) -> Actor:
    color = vivid(rng, (0.6, 1.0))
    panels = dict(pattern=int((STRIPES, CHECKS, SPOTS)[int(rng.integers(3))]), pattern_color=vivid(rng, (0.1, 1.0)),
                  freq=uniform(rng, 2.0, 4.0))
    return Actor("ball", "ground", uniform(rng, 1.0, 4.0), 0.5,
                 dict(color=color, bounce=uniform(rng, 0.5, 2.0), panels=panels))


def pose_ball(p, phase):
    height = p["bounce"] * (1.0 - float(wave(phase)) ** 2)
    turn = rotation(float(wave(phase)) * 0.8)
    return [shadow(0.2), Part(0.0, -0.2 - height, 0.2, 0.2, p["color"], *turn, shade=0.9, **p["panels"])]


def boat(rng) -> Actor:
    hull = vivid(rng, (0.3, 0.95))
    params = dict(hull=hull, length=uniform(rng, 1.5, 3.0), sail=rng.random() < 0.5, stripe=vivid(rng, (0.1, 1.0)),
                  canvas=hsv(0.1, 0.05, 0.95) if rng.random() < 0.5 else vivid(rng, (0.7, 1.0)))
    return Actor("boat", "water", uniform(rng, 0.5, 2.0), 0.3, params)


def pose_boat(p, phase):
    L, roll = p["length"], 0.01 * float(wave(phase))
    parts = [Part(0.0, -0.05 + roll, 0.5 * L, 0.16, p["hull"], box=True, shade=0.5, pattern=BANDS,
                  pattern_color=p["stripe"], freq=2.0)]
    if p["sail"]:
        parts.insert(0, Part(0.05 * L, -0.75, 0.02, 0.6, hsv(0, 0, 0.3), box=True))
        parts.insert(1, Part(-0.05, -0.75 + roll, 0.2, 0.55, p["canvas"], *rotation(0.06), shade=0.4,
                             pattern=BANDS, pattern_color=p["stripe"], freq=4.0))
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
    return [replace(p, x=-p.x, sin=-p.sin) for p in parts]


# Subject heights, as fractions of the frame side, by kind: DAVIS subjects are large and central.
SUBJECT_SIZE = {"quadruped": (0.5, 0.85), "person": (0.6, 0.95), "vehicle": (0.35, 0.6), "boat": (0.4, 0.7),
                "bird": (0.3, 0.5), "ball": (0.3, 0.5)}


def prop(rng, kind: str) -> list[Part]:
    """A still thing standing on the ground, about 1 tall, feet at y = 0: it fills the scene's middle."""
    if kind == "bush":
        leaf = hsv(uniform(rng, 0.2, 0.38), uniform(rng, 0.5, 0.9), uniform(rng, 0.25, 0.6))
        bloom = vivid(rng, (0.7, 1.0)) if rng.random() < 0.4 else leaf * F32(1.4)
        parts = []
        for _ in range(int(rng.integers(8, 16))):
            r = uniform(rng, 0.08, 0.2)
            parts.append(Part(uniform(rng, -0.5, 0.5), -uniform(rng, 0.15, 0.85), r, r * uniform(rng, 0.7, 1.0),
                              leaf * F32(uniform(rng, 0.7, 1.2)), shade=0.9, pattern=SPOTS, pattern_color=bloom,
                              freq=uniform(rng, 2.0, 4.0)))
        return parts
    if kind == "rock":
        stone = hsv(uniform(rng, 0.05, 0.6), uniform(rng, 0.05, 0.3), uniform(rng, 0.35, 0.75))
        moss = hsv(uniform(rng, 0.2, 0.3), 0.6, 0.4)
        return [Part(uniform(rng, -0.4, 0.4), -uniform(rng, 0.15, 0.4), uniform(rng, 0.2, 0.5),
                     uniform(rng, 0.15, 0.35), stone, *rotation(uniform(rng, -0.3, 0.3)), shade=0.95,
                     pattern=BANDS, pattern_color=moss if rng.random() < 0.5 else stone * F32(0.6),
                     freq=uniform(rng, 1.0, 2.0)) for _ in range(int(rng.integers(1, 4)))]
    if kind == "flowers":
        stem = hsv(0.3, 0.7, 0.35)
        parts = []
        for _ in range(int(rng.integers(4, 9))):
            x, top = uniform(rng, -0.5, 0.5), uniform(rng, 0.4, 1.0)
            parts.append(Part(x, -top / 2, 0.025, top / 2, stem, shade=0.3))
            parts.append(Part(x, -top, 0.1, 0.08, vivid(rng, (0.7, 1.0)), shade=0.6, pattern=SPOTS,
                              pattern_color=hsv(0.13, 0.9, 0.95), freq=1.0))
        return parts
    if kind == "parasol":
        cloth, pole = vivid(rng, (0.7, 1.0)), hsv(0, 0, 0.9)
        return [Part(0.0, -0.45, 0.025, 0.45, pole, box=True, shade=0.3),
                Part(0.0, -0.9, 0.6, 0.15, cloth, shade=0.6, pattern=STRIPES, pattern_color=hsv(0, 0, 0.97), freq=6)]
    if kind == "cone":
        orange = hsv(uniform(rng, 0.02, 0.08), 0.95, 0.95)
        return [Part(0.0, -0.3, 0.18, 0.3, orange, box=True, shade=0.5, pattern=BANDS,
                     pattern_color=hsv(0, 0, 0.97), freq=2.0)]
    if kind == "sign":
        board = vivid(rng, (0.5, 1.0))
        return [Part(-0.3, -0.45, 0.03, 0.45, hsv(0, 0, 0.4), box=True, shade=0.3),
                Part(0.3, -0.45, 0.03, 0.45, hsv(0, 0, 0.4), box=True, shade=0.3),
                Part(0.0, -0.85, 0.35, 0.2, board, box=True, shade=0.3, pattern=CHECKS if rng.random() < 0.3 else BANDS,
                     pattern_color=hsv(0, 0, 0.97) if rng.random() < 0.5 else hsv(0, 0, 0.05), freq=3.0)]
    if kind == "crate":
        wood = hsv(uniform(rng, 0.05, 0.1), uniform(rng, 0.4, 0.7), uniform(rng, 0.4, 0.75)) if rng.random() < 0.5 \
            else vivid(rng, (0.4, 0.9))
        return [Part(0.0, -0.3, 0.35, 0.3, wood, box=True, shade=0.6, pattern=BANDS,
                     pattern_color=wood * F32(0.4), freq=uniform(rng, 3.0, 6.0))]
    raise ValueError(f"unknown prop {kind!r}")


# Which props each scene may hold.
PROPS = {
    "meadow": ("bush", "rock", "flowers", "flowers", "sign"),
    "coast": ("rock", "rock", "parasol"),
    "forest": ("bush", "rock", "flowers", "bush"),
    "city": ("cone", "sign", "crate", "bush"),
    "arena": ("cone", "crate", "sign"),
}
