"""See the recordings as a student does: run engine.py and exercise 5, open each .rrd in the real viewer, save PNGs.

Run it from the repo root with the project's environment active (pytest does not collect it):

    python tools/screenshots.py            # eleven PNGs in outputs/screenshots/, then look at every one
    python tools/screenshots.py ex5 spring # some of them
    python tools/screenshots.py --docs     # also refresh the README's pictures in docs/

The viewer runs on a virtual screen: Debian's xvfb and mesa-vulkan-drivers (and xdotool, to park the
mouse pointer where it hovers nothing). Rendering is software-only, so allow 20-60 s per picture.
`rerun FILE --screenshot-to PNG` loads the whole file before it takes the picture; each recording opens
with its time cursor on the last step, so a picture whose cursor sits on the run's last step was taken
after everything had loaded.
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
WINDOW = (1600, 1000)  # logical points; the viewer renders at 2x, so the PNG is 3200 x 2000
# name: the command that writes the recording ({out} is a scratch folder), and the recording it writes there.
# The first two are the README's pictures; then every recording issue 24 names (tests/test_recording.py's LISTED).
CASES = {
    "orbit": (["engine.py", "--system", "orbit", "--out", "{out}"], "engine.rrd"),
    "freefall": (["engine.py", "--system", "freefall", "--out", "{out}"], "engine.rrd"),
    "spring": (["engine.py", "--system", "spring", "--out", "{out}"], "engine.rrd"),
    "spring-dt0.05": (["engine.py", "--system", "spring", "--dt", "0.05", "--out", "{out}"], "engine.rrd"),
    "damped_spring": (["engine.py", "--system", "damped_spring", "--out", "{out}"], "engine.rrd"),
    "damped_spring-300": (["engine.py", "--system", "damped_spring", "--damping", "300", "--out", "{out}"],
                          "engine.rrd"),
    "orbit-dt0.5": (["engine.py", "--system", "orbit", "--dt", "0.5", "--out", "{out}"], "engine.rrd"),
    "orbit-ensemble-1000": (["engine.py", "--system", "orbit", "--ensemble", "1000", "--out", "{out}"], "engine.rrd"),
    "orbit-200k": (["engine.py", "--system", "orbit", "--steps", "200000", "--out", "{out}"], "engine.rrd"),
    # any prediction writes the same recording: these are the same word for every name, not the answers
    "ex5": (["-m", "exercises.ex5_phase_blob", "--predict", "euler=grows, semi_implicit=grows, rk4=grows",
             "--rrd", "{out}/ex5_blob.rrd"], "ex5_blob.rrd"),
    "ex7": (["-m", "exercises.ex7_shadow_energy", "--predict", "spring=as_far, orbit=as_far, freefall=as_far",
             "--rrd", "{out}/ex7_shadow.rrd"], "ex7_shadow.rrd"),
}
DOCS = {"orbit": "recording-orbit.png", "freefall": "recording-freefall.png"}
DOCS_WIDTH = 1200  # README pictures are scaled down and palette-quantized to stay small


def screenshot(rrd: Path, png: Path) -> None:
    """Open `rrd` in the viewer on a virtual screen and save what it shows to `png`."""
    width, height = WINDOW
    park_pointer = f"(sleep 3; xdotool mousemove {width - 60} 12) & " if shutil.which("xdotool") else ""
    # --new: a viewer of our own on a free port, never a hand-off to another one already running
    viewer = (f"{park_pointer}rerun --new --bind 127.0.0.1 --screenshot-to '{png}' "
              f"--window-size {width}x{height} '{rrd}'")
    png.unlink(missing_ok=True)
    shown = subprocess.run(["xvfb-run", "-a", "-s", f"-screen 0 {width}x{height}x24", "bash", "-c", viewer],
                           capture_output=True, text=True, timeout=300, check=False)
    if not png.is_file():
        log = "\n".join((shown.stdout + shown.stderr).splitlines()[-15:])
        sys.exit(f"no screenshot of {rrd} (needs xvfb and mesa-vulkan-drivers); the viewer said:\n{log}")


def shrink(png: Path, out: Path) -> None:
    from PIL import Image

    with Image.open(png) as image:
        height = round(image.height * DOCS_WIDTH / image.width)
        small = image.convert("RGB").resize((DOCS_WIDTH, height), Image.Resampling.LANCZOS)
        small.quantize(colors=128, method=Image.Quantize.MEDIANCUT).save(out, optimize=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--docs", action="store_true", help="also write the README's pictures to docs/")
    parser.add_argument("--out", type=Path, default=ROOT / "outputs" / "screenshots")
    parser.add_argument("cases", nargs="*", metavar="CASE", help=f"some of {', '.join(CASES)} (default all)")
    args = parser.parse_args()
    unknown = sorted(set(args.cases) - set(CASES))
    if unknown:
        parser.error(f"unknown case {unknown[0]!r}; choose from {', '.join(CASES)}")
    if not shutil.which("xvfb-run") or not shutil.which("rerun"):
        sys.exit("needs xvfb-run (apt-get install xvfb mesa-vulkan-drivers) and rerun (activate the environment)")
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as scratch:
        for name in args.cases or CASES:
            run_dir = Path(scratch) / name
            command, recording = CASES[name]
            subprocess.run([sys.executable, *(part.format(out=run_dir) for part in command)], cwd=ROOT, check=True,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                           env={**os.environ, "COURSE_JOURNAL": "off"})  # a maintainer's run: not recorded
            rrd = run_dir / recording
            png = args.out / f"{name}.png"
            screenshot(rrd, png)
            print(f"{png}  ({rrd.stat().st_size / 1e6:.2f} MB recording)")
            if args.docs and name in DOCS:
                shrink(png, ROOT / "docs" / DOCS[name])
                print(f"  -> docs/{DOCS[name]} ({(ROOT / 'docs' / DOCS[name]).stat().st_size / 1e3:.0f} KB)")
    print("Now look at every picture: would a student get the chapter's point at a glance?")
    return 0


if __name__ == "__main__":
    sys.exit(main())
