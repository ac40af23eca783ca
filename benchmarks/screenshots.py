"""Render the HTML reports (headless Chromium) and the GUI (offscreen Qt) for inspection.

Writes benchmarks/results/screenshots/:
- report.{html,png}: the ADIS16405 run 1 gyro record of ../shared/data (counts x 0.05 deg/s,
  100 Hz), checked against datasheet values;
- report_example.{html,png}: the simulated example record (every fitted term visible);
- gui_adev.png: the GUI on ADIS16405 run 1, three channels shown in deg/h;
- gui_fit.png: the GUI's fit view of the example record.

    python benchmarks/screenshots.py
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data" / "imu" / "adis16405" / "run1.npz"
OUT = ROOT / "benchmarks" / "results" / "screenshots"
ADIS = ["--key", "gyro_counts", "--fs", "100", "--scale", "0.05", "--units", "deg/s"]

# ADIS16405 datasheet typical gyro values: angle random walk 2 deg/sqrt(h), in-run bias
# stability 0.007 deg/s; the Allan deviation at 1 s of pure ARW N is N (in deg/s/sqrt(Hz)).
LIMITS = {
    "device": "ADIS16405 datasheet (typical values)",
    "limits": [
        {"quantity": "N", "max": 2.0, "unit": "deg/sqrt(h)"},
        {"quantity": "B", "max": 0.007, "unit": "deg/s"},
        {"quantity": "adev", "tau": 1.0, "max": 2.0 / 60.0, "unit": "deg/s"},
    ],
}


def _browser() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


def render(html: Path, png: Path) -> None:
    """Screenshot ``html`` in headless Chromium and crop the empty page below it."""
    browser = _browser()
    if browser is None:
        print(f"no Chromium: {png.name} not rendered", file=sys.stderr)
        return
    command = [
        browser,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--hide-scrollbars",
        "--window-size=1200,9000",
        f"--screenshot={png}",
        html.as_uri(),
    ]
    subprocess.run(command, check=True, capture_output=True, timeout=180)
    crop_background(png)


def crop_background(path: Path) -> None:
    """Cut the empty page background below the report's content."""
    import numpy as np
    from PIL import Image

    image = Image.open(path).convert("RGB")
    pixels = np.asarray(image).astype(int)
    background = pixels[-1, 0]
    rows = np.flatnonzero(np.any(np.abs(pixels - background).sum(axis=-1) > 6, axis=1))
    if rows.size:
        image.crop((0, 0, image.width, min(image.height, int(rows[-1]) + 24))).save(path)


def reports(work: Path) -> None:
    from allanite.cli import main

    limits = work / "limits.json"
    limits.write_text(json.dumps(LIMITS))
    main(
        [
            "report",
            str(DATA),
            *ADIS,
            "--datasheet",
            str(limits),
            "--title",
            "ADIS16405 run 1 — gyro noise report",
            "-o",
            str(OUT / "report.html"),
        ]
    )
    main(
        [
            "report",
            "--example",
            "--title",
            "Example record — gyro noise report",
            "-o",
            str(OUT / "report_example.html"),
        ]
    )
    for name in ("report", "report_example"):
        render(OUT / f"{name}.html", OUT / f"{name}.png")


def gui() -> None:
    from allanite.gui import create_window

    window = create_window()
    window.resize(1280, 820)
    window.show()
    window.fs_spin.setValue(100.0)
    window.scale_edit.setText("0.05")
    window.units_combo.setCurrentText("deg/s")
    window.key_edit.setText("gyro_counts")
    window.open_file(DATA)
    window.display_combo.setCurrentText("deg/h")
    window.grab_screenshot(OUT / "gui_adev.png")
    window._open_example()
    window._guard(lambda: window.set_view("Fit"))()
    window.grab_screenshot(OUT / "gui_fit.png")
    window.close()


def main() -> None:
    if not DATA.exists():
        sys.exit(f"{DATA} not found (the shared reference data sit beside the repository)")
    OUT.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        reports(Path(tmp))
    gui()
    for path in sorted(OUT.iterdir()):
        print(path.relative_to(ROOT))


if __name__ == "__main__":
    import argparse

    argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    ).parse_args()  # --help describes the run instead of starting it
    main()
