"""Image statistics of the stand-in textures beside natural textures photographed, as a markdown table.

    pip install scikit-image   # for this script only: the natural textures ship inside its wheel
    python benchmarks/texture_statistics.py [--size 128] [--sheet /tmp/standins.png]

Measures the 20 training and 5 held-out stand-in textures of ``dcs_torchrl.textures`` (version
``STANDIN_VERSION``, drawn at ``--size``) and natural textures read from scikit-image's installed
files (nothing is downloaded): its grey brick, grass and gravel photographs, and square crops of its
colour photographs that show one surface — the wooden table of ``coffee`` (two crops), the cat's fur
of ``chelsea`` (two crops), the stained tissue of ``immunohistochemistry`` (two quarters). Each
natural texture is brought to the stand-ins' size as a folder's image would be
(:func:`dcs_torchrl.textures.sets.read_texture`'s centre crop and ``cv2.INTER_AREA`` resize; the
fur and wood crops are 90-150 pixels, so at sizes above that they are upscaled and softer).

Per image, then mean ± sd over each set:

- ``brightness``: the mean Rec. 601 luminance Y in [0, 1];
- ``contrast``, ``saturation``, ``gradient``, ``slope``: :func:`dcs_torchrl.videos.statistics.frame_statistics`
  (RMS contrast of Y, mean HSV saturation, mean |Sobel| of Y in grey levels per pixel, the spectral
  slope of Y's power spectrum: natural images about -2);
- ``colourfulness``: Hasler and Süsstrunk's (2003) M = sqrt(sd(rg)² + sd(yb)²) + 0.3 sqrt(mean(rg)² +
  mean(yb)²) with rg = R - G, yb = (R + G) / 2 - B in grey levels (0: grey; ~15 "slightly", ~33
  "moderately", ~45 "averagely", ~59 "quite" colourful);
- ``edges``: the fraction of pixels on Canny edges of Y (``cv2.Canny`` at thresholds 50 and 150).

The grey photographs have no colour: saturation and colourfulness of the natural set are over its
colour crops only. ``--sheet PATH`` also writes a contact sheet of the 25 stand-ins at 128 pixels
(train 0-19, then val 0-4, five a row). scikit-image is not a dependency of the suite: do not add it.
"""
from __future__ import annotations

import argparse
import sys

import cv2
import numpy as np

from dcs_torchrl.textures import STANDIN_VERSION, TEXTURE_SPLITS, texture_set
from dcs_torchrl.videos.source import squash
from dcs_torchrl.videos.statistics import frame_statistics, luminance

NAMES = ("brightness", "contrast", "saturation", "colourfulness", "gradient", "edges", "slope")
COLOUR_ONLY = ("saturation", "colourfulness")


def natural_textures() -> dict[str, np.ndarray]:
    """uint8 RGB textures by name, from scikit-image's installed files; grey ones as 3 equal channels."""
    try:
        import skimage.data
    except ImportError as error:
        sys.exit(f"{error}: run `pip install scikit-image` first (for this script only).")
    coffee, chelsea, tissue = skimage.data.coffee(), skimage.data.chelsea(), skimage.data.immunohistochemistry()
    out = {
        "wood (coffee, table)": coffee[0:150, 450:600],
        "wood (coffee, corner)": coffee[270:400, 470:600],
        "fur (chelsea, forehead)": chelsea[0:100, 200:300],
        "fur (chelsea, cheek)": chelsea[150:250, 25:125],
        "tissue (immunohistochemistry)": tissue[:256, :256],
        "tissue (immunohistochemistry, 2)": tissue[256:, 256:],
    }
    for name in ("brick", "grass", "gravel"):
        out[name] = np.repeat(getattr(skimage.data, name)()[..., None], 3, axis=-1)
    return {name: np.ascontiguousarray(image) for name, image in out.items()}


def square(image: np.ndarray, size: int) -> np.ndarray:
    """Centre crop to a square and ``cv2.INTER_AREA`` resize, as a texture folder's image."""
    h, w = image.shape[:2]
    side = min(h, w)
    top, left = (h - side) // 2, (w - side) // 2
    return squash(np.ascontiguousarray(image[top : top + side, left : left + side]), size)


def colourfulness(image: np.ndarray) -> float:
    """Hasler and Süsstrunk's colourfulness of a uint8 RGB image (grey levels)."""
    rgb = image.astype(np.float64)
    rg = rgb[..., 0] - rgb[..., 1]
    yb = 0.5 * (rgb[..., 0] + rgb[..., 1]) - rgb[..., 2]
    return float(np.sqrt(rg.std() ** 2 + yb.std() ** 2) + 0.3 * np.sqrt(rg.mean() ** 2 + yb.mean() ** 2))


def statistics(image: np.ndarray) -> dict[str, float]:
    """Every statistic of NAMES for one uint8 RGB image [S, S, 3]."""
    y = luminance(image)
    grey = np.floor(y * 255 + 0.5).astype(np.uint8)
    stats = frame_statistics(image)
    stats["brightness"] = float(y.mean())
    stats["colourfulness"] = colourfulness(image)
    stats["edges"] = float(np.mean(cv2.Canny(grey, 50, 150) > 0))
    return stats


def column(per_image: list[dict[str, float]], name: str) -> str:
    values = np.array([s[name] for s in per_image])
    return f"{values.mean():.3f} ± {values.std():.3f}" if len(values) else "n/a"


def sheet(path: str, size: int = 128) -> None:
    """The 25 stand-ins at ``size`` pixels, five a row, named, written to ``path`` (PNG)."""
    tiles = []
    for split in TEXTURE_SPLITS:
        textures = texture_set(None, split)
        for index in range(len(textures)):
            tile = cv2.cvtColor(textures.image(index, size), cv2.COLOR_RGB2BGR)
            label = textures.names[index].removeprefix("standin-")
            for colour, thickness in (((0, 0, 0), 3), ((255, 255, 255), 1)):
                cv2.putText(tile, label, (3, size - 5), cv2.FONT_HERSHEY_SIMPLEX, 0.33, colour, thickness, cv2.LINE_AA)
            tiles.append(cv2.copyMakeBorder(tile, 2, 2, 2, 2, cv2.BORDER_CONSTANT, value=(40, 40, 40)))
    rows = [np.concatenate(tiles[i : i + 5], axis=1) for i in range(0, len(tiles), 5)]
    if not cv2.imwrite(path, np.concatenate(rows, axis=0)):
        sys.exit(f"could not write the contact sheet to {path}: give a writable path ending in .png.")
    print(f"contact sheet of the {len(tiles)} stand-ins at {size} px: {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128, help="side of every measured texture, pixels")
    parser.add_argument("--sheet", default=None, help="also write a PNG contact sheet of the stand-ins here")
    args = parser.parse_args()
    natural = natural_textures()
    sets = {f"stand-ins train (v{STANDIN_VERSION})": [statistics(t) for t in texture_set(None, "train").images(args.size)],
            f"stand-ins val (v{STANDIN_VERSION})": [statistics(t) for t in texture_set(None, "val").images(args.size)]}
    measured = {name: statistics(square(image, args.size)) for name, image in natural.items()}
    coloured = [s for name, s in measured.items() if natural[name].std(axis=-1).max() > 0]
    sets["natural textures"] = list(measured.values())
    print(f"Texture statistics at {args.size} x {args.size}, mean ± sd over the images "
          f"(natural: {len(measured)} images, {len(coloured)} in colour)\n")
    print("| statistic | " + " | ".join(f"{name} ({len(v)})" for name, v in sets.items()) + " |")
    print("|---|" + "---|" * len(sets))
    for stat in NAMES:
        cells = [column(coloured if (name == "natural textures" and stat in COLOUR_ONLY) else per_image, stat)
                 for name, per_image in sets.items()]
        print(f"| {stat} | " + " | ".join(cells) + " |")
    print("\nNatural textures one by one:\n")
    print("| texture | " + " | ".join(NAMES) + " |")
    print("|---|" + "---|" * len(NAMES))
    for name, s in measured.items():
        print(f"| {name} | " + " | ".join(f"{s[stat]:.3f}" for stat in NAMES) + " |")
    if args.sheet:
        sheet(args.sheet)


if __name__ == "__main__":
    main()
