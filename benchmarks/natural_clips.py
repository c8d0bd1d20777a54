"""Pan clips over natural photographs, and their frame statistics beside the embedded clips'.

    pip install scikit-image scikit-learn   # for this script only; matplotlib is already installed
    python benchmarks/natural_clips.py --out /tmp/natural_clips [--clips 8] [--frames 64] [--size 256]

Builds ``--clips`` videos, each a slow pan and zoom (a smooth camera path, no cuts) across
one photograph that a PyPI package ships inside its wheel — scikit-image's astronaut,
coffee, chelsea, rocket and motorcycle, scikit-learn's china and flower, matplotlib's
grace_hopper — read from the installed files (nothing is downloaded). With more clips than
photographs, each photograph gets further pans along other paths. Every clip is written
as one folder of numbered PNG frames (``<out>/<k>-<photo>/00000.png``, ...), a layout the
suite loads as background videos; clip k's name starts with k, so the first b videos the
suite takes (sorted by name) are the first b clips built, the same as ``--clips b`` builds::

    make_env("cartpole", "swingup", background_dir="/tmp/natural_clips", ...)

(all of them are the ``train`` split: the folder has no ``val/`` sub-folder). Then it
prints, per set, the mean and the minimum over clips of each frame statistic of
:func:`dcs_torchrl.videos.statistics.frame_statistics` (RMS contrast of the Rec. 601
luminance, mean HSV saturation, mean |Sobel| gradient in grey levels per pixel, spectral
slope) for these clips and for the embedded stand-in clips (train and val, version
``dcs_torchrl.videos.EMBEDDED_VERSION``), all at 256x256. The clips are the same bytes
on every run (fixed paths from a seeded numpy generator, OpenCV ``INTER_AREA`` resizes).
A second table gives the mean of each statistic over the first b clips of each set for the
b the benchmarks use (4, 8, 60 and every b up to the set): the first b videos are what an env
with ``num_videos=b`` shows.
Those packages are not dependencies of the suite: do not add them to it.
"""
from __future__ import annotations

import argparse
import shutil
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from dcs_torchrl.videos import EMBEDDED_VERSION, EmbeddedSource, open_source
from dcs_torchrl.videos.statistics import CLIP_NAMES, clip_statistics, summary

SIZE = 256  # the sky texture's side: statistics are measured at this size


def photographs() -> dict[str, np.ndarray]:
    """The RGB uint8 photographs, by name, read from the installed packages' files."""
    try:
        import skimage
        import sklearn.datasets
    except ImportError as error:
        sys.exit(f"{error}: run `pip install scikit-image scikit-learn` first (for this script only).")
    from matplotlib import cbook

    skimage_data = Path(skimage.__file__).parent / "data"
    files = {name: skimage_data / f"{name}.{ext}" for name, ext in
             (("astronaut", "png"), ("coffee", "png"), ("chelsea", "png"), ("rocket", "jpg"))}
    files["motorcycle"] = skimage_data / "motorcycle_left.png"
    sklearn_images = Path(sklearn.datasets.__file__).parent / "images"
    files["china"], files["flower"] = sklearn_images / "china.jpg", sklearn_images / "flower.jpg"
    files["grace_hopper"] = Path(cbook.get_sample_data("grace_hopper.jpg", asfileobj=False))
    images = {}
    for name, path in files.items():
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if image is None:
            sys.exit(f"cannot read {path}: is the package that ships it installed?")
        images[name] = np.ascontiguousarray(image[..., ::-1])
    return images


def smooth(t: np.ndarray, a: float, b: float) -> np.ndarray:
    """From a to b along t in [0, 1], easing in and out."""
    return a + (b - a) * t * t * (3 - 2 * t)


def pan_clip(image: np.ndarray, frames: int, rng: np.random.Generator, size: int = SIZE) -> np.ndarray:
    """uint8 [frames, size, size, 3]: a square window gliding and zooming across ``image``."""
    h, w = image.shape[:2]
    short = min(h, w)
    t = np.linspace(0.0, 1.0, frames)
    side = smooth(t, *(short * rng.uniform(0.45, 0.8, 2)))  # window side in image pixels
    cx0, cx1 = rng.uniform(0.0, 1.0, 2)
    cy0, cy1 = rng.uniform(0.0, 1.0, 2)
    out = np.empty((frames, size, size, 3), np.uint8)
    for i in range(frames):
        s = side[i]
        x = smooth(t[i], cx0, cx1) * (w - s)
        y = smooth(t[i], cy0, cy1) * (h - s)
        x0, y0, x1, y1 = int(round(x)), int(round(y)), int(round(x + s)), int(round(y + s))
        cv2.resize(image[y0:y1, x0:x1], (size, size), dst=out[i], interpolation=cv2.INTER_AREA)
    return out


def build(out: Path, clips: int, frames: int, seed: int = 0) -> list[np.ndarray]:
    """Writes ``clips`` pan clips under ``out`` (replacing it) and returns them."""
    images = photographs()
    names = list(images)
    rng = np.random.default_rng(seed)
    if out.exists():
        shutil.rmtree(out)
    videos = []
    for k in range(clips):
        name = names[k % len(names)]
        clip = pan_clip(images[name], frames, rng)
        folder = out / f"{k:0{len(str(clips - 1))}d}-{name}"  # sorted by name = built order
        folder.mkdir(parents=True)
        for i, frame in enumerate(clip):
            cv2.imwrite(str(folder / f"{i:05d}.png"), np.ascontiguousarray(frame[..., ::-1]))
        videos.append(clip)
    return videos


PREFIXES = (4, 8, 60)  # the b of the benchmarks (easy, medium) and of the paper's background axis


def row(label: str, per_clip: list[dict[str, float]]) -> str:
    stats = summary(per_clip)
    return f"{label:<28}" + "".join(f"{stats[n][0]:>9.3f}{stats[n][1]:>9.3f}" for n in CLIP_NAMES)


def prefix_rows(label: str, per_clip: list[dict[str, float]]) -> list[str]:
    """Per b in PREFIXES (that the set holds): the mean of each statistic over its first b clips."""
    return [f"{f'{label}, first {b}':<28}" + "".join(f"{summary(per_clip[:b])[n][0]:>18.3f}" for n in CLIP_NAMES)
            for b in PREFIXES if b <= len(per_clip)]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="folder to write the clips to (replaced if it exists)")
    parser.add_argument("--clips", type=int, default=8, help="how many clips (8 photographs, then more pans)")
    parser.add_argument("--frames", type=int, default=64, help="frames per clip")
    args = parser.parse_args(argv)
    if args.clips < 1 or args.frames < 2:
        parser.error("--clips must be >= 1 and --frames >= 2")
    out = Path(args.out)
    build(out, args.clips, args.frames)
    natural = open_source(out)  # read back as the suite will: proves the folder loads
    print(f"wrote {len(natural)} clips of {args.frames} frames to {out} (load with background_dir={str(out)!r})")
    print(f"\nframe statistics at {SIZE}x{SIZE}, each the mean over a clip's frames; mean and min over clips")
    print(f"{'':<28}" + "".join(f"{n:>18}" for n in CLIP_NAMES))
    print(f"{'':<28}" + "".join(f"{'mean':>9}{'min':>9}" for _ in CLIP_NAMES))
    sets = {"natural pans": clip_statistics(natural.frames(i, SIZE) for i in range(len(natural)))}
    print(row(f"natural pans ({len(natural)})", sets["natural pans"]))
    for split in ("train", "val"):
        source = EmbeddedSource(split)
        start = time.perf_counter()
        per_clip = clip_statistics(source.frames(i, SIZE) for i in range(len(source)))
        label = f"embedded v{EMBEDDED_VERSION} {split}"
        sets[label] = per_clip
        print(row(f"{label} ({len(source)})", per_clip) + f"   ({time.perf_counter() - start:.0f} s)")
    print("\nthe first b clips of each list (what num_videos=b shows), mean over them")
    print(f"{'':<28}" + "".join(f"{n:>18}" for n in CLIP_NAMES))
    for label in ("natural pans", f"embedded v{EMBEDDED_VERSION} train"):
        print("\n".join(prefix_rows(label, sets[label])))
    print("\ncontrast: std of Rec. 601 luminance in [0, 1]; saturation: mean OpenCV HSV S / 255; "
          "gradient: mean |Sobel_x| + |Sobel_y| / 8 of luminance in grey levels; slope: of the radial power spectrum; "
          "motion: mean |change of luminance| between frames in grey levels; brightness: mean luminance where the "
          "cameras look (dcs_torchrl.videos.statistics)")


if __name__ == "__main__":
    main()
