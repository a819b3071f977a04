"""Run by tests/test_wheel.sh inside a virtual environment without system site-packages
where only the repaired wheel (scripts/wheel.sh) and numpy from PyPI are installed: a
camera read, a warp and a calibration work, and every shared library the package
loads resolves inside the environment, or is one of the system libraries the wheel's
manylinux policy lets it assume (its whitelist, given as the second argument: glibc,
libstdc++, zlib, libX11, ...) or a library those need -- nothing else of Debian's
packages."""

import os
import subprocess
import sys
import sysconfig

import fishcam
import numpy as np
from fishcam.transforms import RandomViewpoint

# Part of every process, in no policy's list.
LOADER = {"linux-vdso.so.1", "ld-linux-x86-64.so.2"}


def rotation(yaw: float, pitch: float) -> np.ndarray:
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    return np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]]) @ np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])


def boards(camera: fishcam.Camera) -> list[tuple[str, np.ndarray]]:
    """Noise-free 9 x 6 boards the camera sees whole."""
    grid = np.zeros((54, 3))
    grid[:, 0] = np.tile(np.arange(9), 6) * 0.1
    grid[:, 1] = np.repeat(np.arange(6), 9) * 0.1
    grid -= grid.mean(axis=0)
    random = np.random.default_rng(1)
    out = []
    while len(out) < 15:
        r = rotation(*random.uniform(-0.6, 0.6, 2))
        centre = np.array([random.uniform(-0.6, 0.6), random.uniform(-0.4, 0.4), random.uniform(0.6, 1.2)])
        pixels, ok = camera.project(grid @ r.T + centre)
        if (
            ok.all()
            and (pixels >= 0).all()
            and (pixels[:, 0] <= camera.width - 1).all()
            and (pixels[:, 1] <= camera.height - 1).all()
        ):
            out.append((f"board{len(out):02d}.png", pixels))
    return out


def shared_libraries() -> list[str]:
    package = os.path.dirname(fishcam.__file__)
    bundled = os.path.join(os.path.dirname(package), "fishcam.libs")
    return [
        os.path.join(folder, name)
        for folder in (package, bundled)
        if os.path.isdir(folder)
        for name in sorted(os.listdir(folder))
        if ".so" in name
    ]


def dependencies(library: str) -> list[tuple[str, str]]:
    """(soname, resolved path or "not found") of everything ldd says library loads."""
    listing = subprocess.run(["ldd", library], check=True, capture_output=True, text=True).stdout
    out = []
    for line in listing.splitlines():
        name = line.split()[0]
        resolved = line.split("=>")[1].split("(")[0].strip() if "=>" in line else name
        out.append((os.path.basename(name), "not found" if "not found" in line else resolved))
    return out


def main() -> None:
    site = sysconfig.get_paths()["purelib"]
    assert fishcam.__file__.startswith(site), f"fishcam from {fishcam.__file__}, not the environment's {site}"
    assert not [p for p in sys.path if "dist-packages" in p], f"Debian's packages visible: {sys.path}"

    camera = fishcam.Camera.read(os.path.join(sys.argv[1], "kannala_brandt.yaml")).resized(320, 241)
    image = np.random.default_rng(0).integers(0, 256, (241, 320, 3), dtype=np.uint8)
    out = RandomViewpoint(camera, preset="medium")(image=image, seed=3)
    assert out["image"].shape == image.shape and out["image"].dtype == np.uint8
    assert not np.array_equal(out["image"], image), "the warp changed nothing"

    result = fishcam.calibrate(boards(camera), (9, 6), 0.1, (320, 241), "kannala-brandt", threads=1)
    truth = camera.parameters[0] * camera.pixel_scale[0]
    assert result.rms_px < 1e-6, result.rms_px
    assert abs(result.parameters["f"] - truth) < 1e-6 * truth, (result.parameters["f"], truth)

    libraries = shared_libraries()
    assert any("_fishcam" in os.path.basename(p) for p in libraries), libraries
    whitelist = set(sys.argv[2].split(","))
    loaded = {
        (os.path.basename(library), name, resolved) for library in libraries for name, resolved in dependencies(library)
    }
    from_system = {(name, resolved) for _, name, resolved in loaded if not resolved.startswith(site)}
    # What the whitelisted libraries load themselves (libX11's libxcb, ...) comes with them.
    allowed = set(LOADER) | whitelist
    for name, resolved in from_system:
        if name in whitelist and resolved != "not found":
            allowed |= {dependency for dependency, _ in dependencies(resolved)}
    outside = sorted(
        f"{library}: {name} => {resolved}"
        for library, name, resolved in loaded
        if not resolved.startswith(site) and (name not in allowed or resolved == "not found")
    )
    assert not outside, "libraries from outside the wheel:\n" + "\n".join(outside)
    assumed = sorted({name for name, _ in from_system if name in whitelist})
    print(
        f"wheel_check: a camera read, a warp and a calibration; {len(libraries)} shared libraries in the wheel, "
        f"from the system only what the manylinux policy assumes: {', '.join(assumed)}"
    )


if __name__ == "__main__":
    main()
