"""A wheel of the checkout, installed in a fresh venv outside it, runs.

The wheel is built the way a release is: the checkout's files (tracked, plus new ones git
does not ignore) are copied out, an sdist is made of them (so MANIFEST.in must carry the C
sources and the profiles) and the wheel is built from the unpacked sdist, so nothing left
in the checkout's build/ can slip into it. The fresh venv gets the wheel with --no-deps and,
instead of a download, links to exactly the distributions its Requires-Dist name (and
theirs, transitively) in the dev venv: a dependency the code uses but the metadata does not
declare is missing there, and the run fails. No .pth points at the dev venv, so its editable
hand_service cannot come in. Then, from a directory outside the checkout: `hand-service run
--duration 2`, `hand-service trials` on a shipped profile named bare, and every shipped
profile loads (includes and the DBC resolved beside the installed profile).
"""

from __future__ import annotations

import email.parser
import importlib.metadata as md
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import tarfile
import venv
import zipfile
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[2]
NAME = "hand-service"


BUILD_WARNING = re.compile(r"(?i)warn|deprecat")


def run(argv: list[str | Path], cwd: Path, env: dict[str, str] | None = None,
        timeout: float = 120) -> subprocess.CompletedProcess[str]:
    done = subprocess.run([str(a) for a in argv], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout, check=False)
    shown = " ".join(str(a) if len(str(a)) < 80 else "<...>" for a in argv)
    assert done.returncode == 0, f"{shown} exited {done.returncode}\n{done.stdout}\n{done.stderr}"
    return done


def pip_env() -> dict[str, str]:
    """No pip configuration of this machine (indexes, find-links): the build needs none."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("PIP_")}
    return env | {"PIP_CONFIG_FILE": os.devnull, "PIP_DISABLE_PIP_VERSION_CHECK": "1"}


def checkout_files() -> list[str]:
    """What the next commit could hold: tracked files that exist, and untracked ones not ignored."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs a git checkout")
    listed = run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], ROOT).stdout
    return sorted({name for name in listed.split("\0") if name and (ROOT / name).is_file()})


def build_wheel(tmp: Path) -> Path:
    """checkout copy -> sdist -> wheel, with this interpreter's setuptools and cffi; neither
    step may print a warning (a deprecation, a MANIFEST.in pattern that matches nothing)."""
    src = tmp / "src"
    for name in checkout_files():
        (src / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, src / name)
    made = run([sys.executable, "-c", "import sys; from setuptools import build_meta; "
                "print(build_meta.build_sdist(sys.argv[1]))", tmp / "sdist"], src)
    sdist = made.stdout.split()[-1]
    with tarfile.open(tmp / "sdist" / sdist) as archive:
        safe = {"filter": "data"} if hasattr(tarfile, "data_filter") else {}  # 3.10.12+, 3.11.4+
        archive.extractall(tmp / "unpacked", **safe)
    (unpacked,) = (tmp / "unpacked").iterdir()
    built = run([sys.executable, "-m", "pip", "wheel", ".", "--no-deps", "--no-build-isolation",
                 "--no-index", "-w", tmp / "wheel"], unpacked, pip_env())
    output = (made.stdout + made.stderr + built.stdout + built.stderr).splitlines()
    warnings = [line for line in output if BUILD_WARNING.search(line)]
    assert warnings == [], "the build warns:\n" + "\n".join([*warnings, "--- all of it:", *output])
    (wheel,) = (tmp / "wheel").glob("*.whl")
    return wheel


def requirements(metadata: md.PackageMetadata | email.message.Message,
                 extras: tuple[str, ...] = ()) -> list[Requirement]:
    """The Requires-Dist that apply here, for the base install plus `extras`."""
    found = []
    for line in metadata.get_all("Requires-Dist") or []:
        req = Requirement(line)
        if req.marker is None or any(req.marker.evaluate({"extra": e}) for e in ("", *extras)):
            found.append(req)
    return found


def closure(wanted: list[Requirement]) -> dict[str, md.Distribution]:
    """The dev venv's distributions that satisfy `wanted`, and their own requirements."""
    found: dict[str, md.Distribution] = {}
    todo = [(req, "") for req in wanted]
    seen: set[tuple[str, tuple[str, ...]]] = set()
    while todo:
        req, why = todo.pop()
        key = canonicalize_name(req.name)
        if (key, tuple(sorted(req.extras))) in seen:
            continue
        seen.add((key, tuple(sorted(req.extras))))
        try:
            dist = md.distribution(req.name)
        except md.PackageNotFoundError:
            pytest.fail(f"{req}{why} is not installed in {sys.prefix}")
        assert req.specifier.contains(dist.version, prereleases=True), \
            f"{req}{why}: {sys.prefix} has {dist.version}"
        found[key] = dist
        why = f" (for {dist.metadata['Name']})"
        todo += [(sub, why) for sub in requirements(dist.metadata, tuple(req.extras))]
    return found


def link_distributions(dists: dict[str, md.Distribution], site: Path) -> None:
    """Symlink each distribution's top-level files and folders (from its RECORD) into `site`."""
    for key, dist in dists.items():
        assert dist.files is not None, f"{key}: no RECORD, cannot tell its files"
        home = Path(dist.locate_file(""))
        tops = {file.parts[0] for file in dist.files if file.parts[0] not in ("..", "__pycache__")}
        for top in sorted(tops):
            if top.endswith(".pth"):
                continue  # nothing from the dev venv runs at start-up
            target = site / top
            if not target.exists() and (home / top).exists():
                target.symlink_to(home / top)


PROBE = """
import importlib.metadata as md, json, sys
from pathlib import Path
import hand_service, rtcore
from hand_service.config.profile import PROFILE_DIR, load_profile
from hand_service.version import software_version
owners = md.packages_distributions()
deps = {}
for name in json.loads(sys.argv[1]):
    dist = md.distribution(name)
    for module in [m for m, names in owners.items() if dist.metadata["Name"] in names]:
        if not module.startswith("_"):
            __import__(module)
    deps[name] = [dist.version, str(dist.locate_file(""))]
loaded = {p.name: str(load_profile(p.name).path) for p in sorted(PROFILE_DIR.glob("*.yaml"))}
dist = md.distribution("hand-service")
print(json.dumps({"prefix": sys.prefix, "path": sys.path, "hand_service": hand_service.__file__,
                  "rtcore": rtcore.__file__, "profile_dir": str(PROFILE_DIR), "loaded": loaded,
                  "profile_dir_exists": PROFILE_DIR.is_dir(),
                  "version": software_version(), "package_version": hand_service.__version__,
                  "dist": str(dist.locate_file("")), "deps": deps,
                  "editable_finder": [m for m in sys.modules if "editable" in m]}))
"""


@pytest.mark.install
def test_wheel_runs_in_a_fresh_venv_outside_the_checkout(tmp_path: Path) -> None:
    assert not tmp_path.resolve().is_relative_to(ROOT), "the fresh venv must live outside the checkout"
    wheel = build_wheel(tmp_path)
    with zipfile.ZipFile(wheel) as archive:
        shipped = set(archive.namelist())
        (metadata,) = [n for n in shipped if n.endswith(".dist-info/METADATA")]
        wheel_meta = email.parser.Parser().parsestr(archive.read(metadata).decode())

    # every module of the checkout and every profile is in the wheel
    files = checkout_files()
    missing = [f for f in files if f.startswith(("hand_service/", "rtcore/")) and f.endswith(".py")
               and f not in shipped]
    missing += [f for f in files if f.startswith("firmware_profiles/")
                and f"hand_service/{f}" not in shipped]
    assert missing == [], f"not in {wheel.name}: {missing}"
    assert any(n.startswith("rtcore/_rtcore.") and n.endswith(".so") for n in shipped)

    # a fresh venv: the wheel without its dependencies, then links to exactly those it declares
    fresh = tmp_path / "venv"
    venv.EnvBuilder(with_pip=False, symlinks=True).create(fresh)
    python = fresh / "bin" / "python"
    site = Path(run([python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                    tmp_path).stdout.strip())
    run([sys.executable, "-m", "pip", "--python", python, "install", "--no-deps", "--no-index",
         "--quiet", wheel], tmp_path, pip_env())
    declared = requirements(wheel_meta)
    link_distributions(closure(declared), site)

    work = tmp_path / "work"  # cwd: no checkout, no profiles beside it
    work.mkdir()
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "PYTHONSTARTUP")}
    env |= {"PATH": f"{fresh / 'bin'}{os.pathsep}{env.get('PATH', '')}", "PYTHONNOUSERSITE": "1",
            "HAND_SERVICE_SOCKET": str(tmp_path / "api.sock"), "MPLBACKEND": "Agg"}

    probe = json.loads(run([python, "-c", PROBE, json.dumps([r.name for r in declared])], work,
                           env).stdout)
    fresh_prefix = str(fresh)
    assert probe["prefix"] == fresh_prefix
    assert not any(p and Path(p).resolve().is_relative_to(ROOT) for p in probe["path"]), probe["path"]
    for key in ("hand_service", "rtcore", "profile_dir", "dist"):
        assert probe[key].startswith(site.as_posix()), f"{key} from {probe[key]}, not the fresh venv"
    assert probe["editable_finder"] == []
    assert probe["profile_dir_exists"], f"{probe['profile_dir']} is not in the wheel"
    # the declared dependencies resolve inside the fresh venv and satisfy their specifiers
    for req in declared:
        version, where = probe["deps"][req.name]
        assert where.startswith(site.as_posix()), f"{req.name} from {where}"
        assert req.specifier.contains(version, prereleases=True), f"{req}: {version}"
    # every shipped profile loads by bare name, includes and DBC resolved beside it
    assert sorted(probe["loaded"]) == sorted(Path(f).name for f in files
                                             if f.startswith("firmware_profiles/") and f.endswith(".yaml"))
    assert all(p.startswith(probe["profile_dir"]) for p in probe["loaded"].values())
    # outside a checkout the version is the package's (git describe finds nothing)
    outside_git = subprocess.run(["git", "-C", site, "rev-parse"], capture_output=True,
                                 check=False).returncode != 0 if shutil.which("git") else True
    if outside_git:
        assert probe["version"] == probe["package_version"]

    cli = fresh / "bin" / "hand-service"
    done = run([cli, "run", "--duration", "2"], work, env)
    assert "stopped (duration)" in done.stdout + done.stderr
    run([cli, "trials", "pairs", "--profile", "serial-v1.yaml", "--finger", "index", "--out", "out"],
        work, env)
    assert [p.name for p in (work / "out").iterdir()] == ["index_pairs_00.csv"]


def test_the_checkout_profiles_are_the_package() -> None:
    """In the editable install, hand_service.firmware_profiles is the checkout's folder (the
    profile module falls back to that folder without an install, which would hide a lost
    mapping here)."""
    from hand_service.config.profile import PROFILE_DIR

    spec = importlib.util.find_spec("hand_service.firmware_profiles")
    assert spec is not None and spec.origin is not None, "not mapped: reinstall (make)"
    assert Path(spec.origin).resolve().parent == ROOT / "firmware_profiles"
    assert PROFILE_DIR.resolve() == ROOT / "firmware_profiles"
