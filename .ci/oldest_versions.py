"""The oldest numpy, scipy and numba that pyproject.toml allows and that have a wheel for this Python, as pip pins
("numpy==1.26.0 scipy==1.11.2 numba==0.59.0"): for .ci/run's versions block.  Asks pip's index (its
list, then a dry run per candidate from the floor up until one has a wheel for this Python); pyproject.toml's floors
are the only input, so raising a floor moves the test."""

import re
import subprocess
import sys
import tomllib


def key(version):
    return tuple(int(x) for x in re.findall(r"\d+", version))


def installable(name, version):
    """Whether pip finds a wheel of ``name==version`` for this interpreter (no source build, nothing installed)."""
    r = subprocess.run([sys.executable, "-m", "pip", "install", "--dry-run", "--quiet", "--only-binary=:all:",
                        "--no-deps", "--ignore-installed", f"{name}=={version}"], capture_output=True, text=True)
    return r.returncode == 0


def main():
    with open("pyproject.toml", "rb") as fh:
        deps = tomllib.load(fh)["project"]["dependencies"]
    floors = {m.group(1): m.group(2) for m in (re.match(r"(numpy|scipy|numba)>=([0-9.]+)", d) for d in deps) if m}
    pins = []
    for name in ("numpy", "scipy", "numba"):
        out = subprocess.run([sys.executable, "-m", "pip", "index", "versions", name, "--only-binary=:all:"],
                             capture_output=True, text=True, check=True).stdout
        listed = re.search(r"Available versions: (.*)", out).group(1).split(", ")
        fit = sorted((v for v in listed if re.fullmatch(r"[0-9.]+", v) and key(v) >= key(floors[name])), key=key)
        # the index lists every release; the first whose wheel this interpreter can install (a dry run)
        pins.append(next(f"{name}=={v}" for v in fit if installable(name, v)))
    print(" ".join(pins))


if __name__ == "__main__":
    main()
