"""The course's writer (curriculum/common/outputs.py) and engine.py's files: written whole or not at all, the
previous pair kept on any failure, never through another user's link; bad --out is one line and exit 2. Real file
systems, links, processes and signals; what is not defended case by case is docs/DEVELOPING.md's limits table."""

import contextlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest

import engine as chapter
from conftest import REPO
from conftest import run as run_alone
from curriculum.common import outputs
from curriculum.common.outputs import OutputError, content_id, write_run

SLOW = pytest.mark.slow  # whole engine runs, several with a recording: the full suite runs them, not the quick tier
PAIR = ("engine.rrd", "metrics.json")  # recording first, the index last: the order engine.py writes them
ENGINE = REPO / "engine.py"


def listing(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def previous_pair(folder: Path) -> dict:
    folder.mkdir(parents=True, exist_ok=True)
    files = {"engine.rrd": b"old recording\n", "metrics.json": b'{"old": true}\n'}
    for name, data in files.items():
        (folder / name).write_bytes(data)
    return files


def assert_unchanged(folder: Path, files: dict) -> None:
    assert listing(folder) == sorted(files), "a temporary file or a stray folder was left behind"
    assert {name: (folder / name).read_bytes() for name in files} == files


def engine(*args, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ENGINE), *map(str, args)], cwd=kwargs.pop("cwd", REPO),
                          capture_output=True, text=True, timeout=120, **kwargs)


def assert_one_line(result, code: int, *words: str) -> None:
    assert result.returncode == code and len(result.stderr.splitlines()) == 1, (result.returncode, result.stderr)
    assert all(word in result.stderr for word in words), result.stderr


def recording_id(path: Path) -> str:
    (recording,) = pytest.importorskip("rerun.chunk").RrdReader(path).recordings()
    return recording.recording_id


# --- the writer ---


def test_both_files_are_replaced_with_the_usual_mode_and_nothing_else_is_left(tmp_path):
    out = tmp_path / "a" / "b"
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    write_run(out, {"engine.rrd": b"\x00rrd", "metrics.json": "{}\n"})
    (out / "metrics.json").unlink()
    (out / "metrics.json").symlink_to(victim)  # a link in a file's place is replaced, never followed
    write_run(out, {"engine.rrd": b"\x00rrd", "metrics.json": "{}\n"})
    assert listing(out) == sorted(PAIR) and (out / "metrics.json").read_text() == "{}\n"
    assert victim.read_text() == "precious\n" and not (out / "metrics.json").is_symlink()
    mask = os.umask(0)
    os.umask(mask)
    assert (out / "metrics.json").stat().st_mode & 0o777 == 0o666 & ~mask
    assert content_id('{"a": 1}\n') == content_id(b'{"a": 1}\n') != content_id('{"a": 2}\n')


def test_a_failed_second_rename_says_which_file_is_new(tmp_path, monkeypatch):
    """Injected at the OS boundary (for real: chattr +i or a mount point, see the limits table)."""
    previous_pair(tmp_path)
    real = os.replace

    def second_fails(source, target):
        if Path(target).name == "metrics.json":
            raise PermissionError(1, "Operation not permitted")
        real(source, target)

    monkeypatch.setattr(outputs.os, "replace", second_fails)
    with pytest.raises(OutputError) as failure:
        write_run(tmp_path, {"engine.rrd": b"new", "metrics.json": b"new"})
    assert str(failure.value) == f"cannot write {tmp_path / 'metrics.json'}: Operation not permitted; only" \
                                 f" engine.rrd in {tmp_path} is new"
    assert listing(tmp_path) == sorted(PAIR)


@contextlib.contextmanager
def small_tmpfs(kib: int):
    """A real, nearly empty file system of `kib` KiB, or a skip if this machine cannot mount one."""
    where = Path(tempfile.mkdtemp(prefix="tmpfs-"))
    if os.geteuid() != 0 or not shutil.which("mount") or subprocess.run(
            ["mount", "-t", "tmpfs", "-o", f"size={kib}k", "tmpfs", str(where)], capture_output=True).returncode:
        where.rmdir()
        pytest.skip("cannot mount a tmpfs here (needs root and CAP_SYS_ADMIN)")
    try:
        yield where
    finally:
        subprocess.run(["umount", str(where)], check=True)
        where.rmdir()


@SLOW
def test_engine_on_a_full_disk_is_one_line_and_keeps_the_previous_pair():
    with small_tmpfs(96) as disk:
        before = previous_pair(disk / "out")
        result = engine("--smoke", "--out", disk / "out")  # the recording is ~130 KB: it cannot fit
        assert_one_line(result, 1, "No space left on device", "were left as they were")
        assert_unchanged(disk / "out", before)


@SLOW
def test_runs_started_together_into_missing_folders_each_leave_a_whole_pair(tmp_path):
    """Six at one instant (as a course's CI starts them): three into nested folders that do not exist yet, three
    with a recording into one folder, where the pair that stays must come from one run."""
    go = tmp_path / "go"
    outs = [tmp_path / "new", tmp_path / "new" / "sub", tmp_path / "new" / "sub" / "deeper"] + [tmp_path / "one"] * 3
    runs = [subprocess.Popen(["sh", "-c", 'until [ -e "$0" ]; do sleep 0.01; done; exec "$@"', str(go),
                              sys.executable, str(ENGINE), "--smoke", "--seed", str(seed), "--out", str(out),
                              *(["--no-rerun"] if seed < 3 else [])], cwd=REPO, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True) for seed, out in enumerate(outs)]
    go.touch()
    assert [(run.wait(timeout=120), run.stderr.read()) for run in runs] == [(0, "")] * 6
    assert listing(tmp_path / "one") == sorted(PAIR)
    metrics = json.loads((tmp_path / "one" / "metrics.json").read_text())
    assert recording_id(tmp_path / "one" / "engine.rrd") == metrics["run_id"] and metrics["seed"] in (3, 4, 5)
    assert json.loads((tmp_path / "new" / "sub" / "deeper" / "metrics.json").read_text())["seed"] == 2


# --- bad --out: one line, exit 2, before the run, nothing made ---

BAD_OUT = {
    "is a file": ("file", "file cannot hold files: file is a file"),
    "is under a file": ("file/sub", "file/sub cannot hold files: file is a file"),
    "under /proc": ("/proc/ch3.3-out", "/proc exists but does not let files or folders be created in it"),
    "under /sys": ("/sys/kernel/ch3.3-out", "cannot create a file in /sys/kernel/ch3.3-out"),
    "dangling symlink": ("dangling", "is a symbolic link to nowhere, which does not exist"),
    "looping symlink": ("loop", "a symbolic link that loops"),
    "300-character name": (f"new/{'x' * 300}/out", "a name in it is 300 characters"),
    "metrics.json is a folder": ("taken", "metrics.json is a folder"),
    "empty": ("", "the output folder is empty"),
}


@pytest.mark.parametrize("case", BAD_OUT)
def test_an_out_that_cannot_take_the_files_is_one_line_before_the_run(case, tmp_path, monkeypatch, capsys):
    out, words = BAD_OUT[case]
    (tmp_path / "file").touch()
    (tmp_path / "dangling").symlink_to("nowhere")
    (tmp_path / "loop").symlink_to("loop")
    (tmp_path / "taken" / "metrics.json").mkdir(parents=True)
    before = sorted(tmp_path.rglob("*"))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as stop:
        chapter.main(["--steps", "10000000", "--no-rerun", "--out", out])  # refused before 10 M steps
    err = capsys.readouterr().err
    assert stop.value.code == 2 and len(err.splitlines()) == 1 and "--out" in err
    assert words in err and sorted(tmp_path.rglob("*")) == before


OTHER_USER = 65533  # any uid but ours and nobody's: the user who plants the link


@SLOW
def test_a_symlink_another_user_planted_in_a_sticky_folder_is_refused(tmp_path):
    """A sticky folder everyone may write to (like /tmp), where another user made `out` -> a folder of theirs;
    `mine` is our own link leading to theirs. (Linux's fs.protected_symlinks, off on some machines, would refuse.)"""
    if os.geteuid() != 0:
        pytest.skip("making a link that belongs to another user needs root")
    shared, theirs = tmp_path / "shared", tmp_path / "theirs"
    shared.mkdir(mode=0o1777)
    shared.chmod(0o1777)
    (theirs / "deeper").mkdir(parents=True)
    (theirs / "metrics.json").write_text("theirs\n")
    (shared / "out").symlink_to(theirs)
    (tmp_path / "mine").symlink_to(shared / "out")
    for path in (theirs, theirs / "deeper", theirs / "metrics.json", shared / "out"):
        os.lchown(path, OTHER_USER, OTHER_USER)
    for out in ("shared/out", "shared/out/deeper", "mine"):
        result = engine("--smoke", "--no-rerun", "--out", tmp_path / out)
        assert_one_line(result, 2, "--out", f"goes through {shared / 'out'}, a symbolic link that user {OTHER_USER}")
        with pytest.raises(OutputError) as refused:  # the writer checks again: a link planted after the check
            write_run(tmp_path / out, {"metrics.json": "{}\n"})
        assert refused.value.exit_code == 2 and (theirs / "metrics.json").read_text() == "theirs\n"
    assert listing(theirs) == ["deeper", "metrics.json"] and listing(theirs / "deeper") == []
    os.lchown(shared / "out", os.geteuid(), os.getegid())  # our own link in a shared folder is followed
    assert engine("--smoke", "--no-rerun", "--out", shared / "out").returncode == 0


# --- signals, memory, a closed pipe: one line, the files whole ---

AT_A_MOMENT = textwrap.dedent("""
    import os, signal, sys
    from curriculum.common import interrupts
    interrupts.install("engine.py")
    import engine, engine_recording
    from curriculum.common import outputs
    signame, where, attribute, out = sys.argv[1:5]
    owner = engine_recording if where == "engine_recording" else outputs.os
    real = getattr(owner, attribute)
    def signal_here(*args, **kwargs):  # the signal lands at this exact moment of the run
        setattr(owner, attribute, real)
        result = real(*args, **kwargs)
        os.kill(os.getpid(), getattr(signal, signame))
        return result
    setattr(owner, attribute, signal_here)
    sys.exit(engine.main(["--smoke", "--out", out]))
""")
MOMENTS = {  # where the signal lands -> the signal, and what the one line says about the files
    "while the recording is built": ("SIGINT", "engine_recording", "log_curves", "interrupted: no file was written"),
    "while a file is synced": ("SIGTERM", "os", "fsync", "terminated: engine.rrd and metrics.json in {out} were written"
                                                         " before that"),
    "between the two renames": ("SIGINT", "os", "replace", "interrupted: engine.rrd and metrics.json in {out} were"
                                                           " written before that"),
}


@SLOW
@pytest.mark.parametrize("moment", MOMENTS)
def test_a_signal_at_a_moment_of_the_write_is_one_line_and_leaves_a_whole_pair(moment, tmp_path):
    signame, where, attribute, said = MOMENTS[moment]
    before = previous_pair(tmp_path)
    result = subprocess.run([sys.executable, "-c", AT_A_MOMENT, signame, where, attribute, str(tmp_path)], cwd=REPO,
                            capture_output=True, text=True, timeout=120)
    assert (result.returncode, result.stderr) == ({"SIGINT": 130, "SIGTERM": 143}[signame],
                                                  said.format(out=tmp_path) + "\n")
    assert listing(tmp_path) == sorted(PAIR)  # no temporary file left
    if "written before" in said:
        assert recording_id(tmp_path / "engine.rrd") == json.loads((tmp_path / "metrics.json").read_text())["run_id"]
    else:
        assert_unchanged(tmp_path, before)


@SLOW
def test_out_of_memory_at_the_step_cap_is_one_line(tmp_path):
    import resource

    code = "import re, engine; print(re.search(r'VmSize:\\s+(\\d+)', open('/proc/self/status').read()).group(1))"
    loaded = int(subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True).stdout)
    limit = loaded * 1024 + 30 * 2**20  # what the imports need and 30 MB: less than one 80 MB energy history
    result = engine("--steps", "10000000", "--integrator", "euler", "--no-rerun", "--out", tmp_path / "out",
                    preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, (limit, limit)))
    assert_one_line(result, 1, "not enough memory", "no file was written")
    assert listing(tmp_path) == []


@SLOW
def test_stdout_closed_early_is_one_line_and_the_files_are_whole(tmp_path):
    run = subprocess.Popen([sys.executable, str(ENGINE), "--smoke", "--out", str(tmp_path)], cwd=REPO,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert run.stdout.readline().startswith("[ch3.3-engine]")  # like `| head -1`
    run.stdout.close()
    assert run.wait(timeout=120) == 1
    assert run.stderr.read() == f"engine.py: error: Broken pipe; engine.rrd and metrics.json in {tmp_path} were" \
                                " written before that\n"
    assert recording_id(tmp_path / "engine.rrd") == json.loads((tmp_path / "metrics.json").read_text())["run_id"]


# --- the run's numbers at the edges: the files are still written, strict JSON ---


def run_here(capsys, *args) -> tuple:
    """engine.main(args) in this process with every warning an error: (exit code, stdout, stderr)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code = chapter.main([str(arg) for arg in args])
    printed = capsys.readouterr()
    return code, printed.out, printed.err


def strict_json(path: Path) -> dict:
    return json.loads(path.read_text(), parse_constant=lambda constant: pytest.fail(f"{constant} in {path}"))


VERDICTS = {  # flags -> what the report says of the ordering
    "drifts that overflow": (["--dt", "1.33e154", "--steps", "1"], "diverged: energy overflowed at step 1"),
    "semi-implicit out of its band": (["--dt", "2"], "cannot judge, semi_implicit left its band (rel_max {rel_max:.3g};"
                                                     " try a smaller --dt)"),
    "a run too short to drift": (["--dt", "1e-300", "--steps", "3"], "cannot judge, every drift is round-off (more"
                                                                     " --steps or a larger --dt)"),
    "a run that does not move": (["--dt", "1e-9", "--steps", "10"], "cannot judge, every drift is round-off"),
    "a small drift": (["--dt", "1e-6", "--steps", "100"], "as expected"),
}


@pytest.mark.parametrize("case", VERDICTS)
def test_the_verdict_judges_only_what_the_drifts_can_tell(case, tmp_path, capsys):
    """Not 'UNEXPECTED' for drifts that are round-off, overflowed or out of semi-implicit Euler's band."""
    flags, said = VERDICTS[case]
    code, out, err = run_here(capsys, *flags, "--no-rerun", "--out", tmp_path)
    drift = strict_json(tmp_path / "metrics.json")["drift"]
    assert code == 0 and (err == "" or "too small to move" in err) and said.format(**drift["semi_implicit"]) in out
    if case == "drifts that overflow":  # finite energies whose relative error overflows
        assert all(drift[name]["diverged"] and drift[name]["energy_overflow_step"] == 1 for name in ("euler",
                                                                                                    "semi_implicit"))
        assert "cannot judge" in out
    if case == "semi-implicit out of its band":
        assert not drift["semi_implicit"]["diverged"] and drift["semi_implicit"]["rel_max"] > 1.0


@pytest.mark.parametrize("members", [3, 4])  # an odd and an even count: the median of two values can overflow
def test_an_ensemble_whose_drifts_overflow_counts_them_as_diverged(members, tmp_path, capsys):
    code, _, err = run_here(capsys, "--ensemble", members, "--dt", "1.33e154", "--steps", "1", "--out", tmp_path)
    assert code == 0 and err == ""
    block = strict_json(tmp_path / "metrics.json")["ensemble"]
    single = {name: [chapter.energy_drift(run_alone("orbit", name, dt=1.33e154, steps=1, seed=seed)[2])["diverged"]
                     for seed in range(members)] for name in block["drift"]}
    assert {name: drift["diverged"] for name, drift in block["drift"].items()} == \
           {name: sum(flags) for name, flags in single.items()}
    assert single["euler"][0]  # seed 0's euler: finite energies whose relative error overflows


@pytest.mark.parametrize("system", list(chapter.SYSTEMS))
def test_a_timestep_too_small_to_move_the_state_is_warned_about(system, tmp_path, capsys):
    code, _, err = run_here(capsys, "--dt", "1e-320", "--system", system, "--no-rerun", "--out", tmp_path)
    assert code == 0
    assert err.startswith("engine.py: warning: --dt 1e-320 is too small to move the state") and err.count("\n") == 1
    assert run_here(capsys, "--dt", "1e-3", "--system", system, "--no-rerun", "--out", tmp_path)[2] == ""


def test_a_no_rerun_run_beside_an_older_recording_says_so_on_stdout(tmp_path, capsys):
    assert run_here(capsys, "--smoke", "--out", tmp_path)[0] == 0
    code, out, err = run_here(capsys, "--smoke", "--no-rerun", "--seed", "1", "--out", tmp_path)
    assert code == 0 and err == ""
    notes = [line for line in out.splitlines() if "engine.rrd" in line]
    assert notes == [f"note: {tmp_path / 'engine.rrd'} is from an earlier run (this one wrote no recording)"]
    assert recording_id(tmp_path / "engine.rrd") != strict_json(tmp_path / "metrics.json")["run_id"]


@pytest.mark.parametrize("flags", [["--system", "damped_spring", "--dt", "100", "--damping", "1e6", "--steps", "5"],
                                   ["--system", "damped_spring", "--dt", "1e12", "--steps", "3"],
                                   ["--dt", "1e-320", "--ensemble", "3"]])
def test_overflowing_and_unmoving_runs_write_their_files(flags, tmp_path, capsys):
    """numpy's round() of a float64 past 1.8e296 gave inf, which strict JSON refused after the run; an ensemble
    whose every error is log10(0) gave the recording no range to unpack. Both were tracebacks."""
    assert chapter.main([*flags, "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    assert recording_id(tmp_path / "engine.rrd") == strict_json(tmp_path / "metrics.json")["run_id"]
