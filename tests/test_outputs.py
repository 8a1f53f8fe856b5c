"""The course's writer (curriculum/common/outputs.py): a run's files are never lost, mixed up or redirected.

Real file systems throughout: a small tmpfs for a full disk where this machine lets us mount one,
real symlinks, real folders in a file's place, real processes racing for one folder, a real
unprivileged user for permissions. Where the OS cannot give us the failure, it is injected at the
OS boundary (os.write, os.rename), and the test says so.
"""

import contextlib
import errno
import fcntl
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import pytest

import engine as chapter
from conftest import NOBODY, REPO, as_nobody
from conftest import run as run_alone
from curriculum.common import outputs
from curriculum.common.outputs import OutputError, content_id, folder_problem, write_run

# Every case here starts fresh interpreters, full disks, concurrent writers and signals: the
# maintainers' robustness suite, run in full by CI (`pytest`), not by the quick `pytest -m "not slow"`.
pytestmark = pytest.mark.slow

PAIR = ("engine.rrd", "metrics.json")  # recording first, the index last: the order engine.py writes them


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
    for name, data in files.items():
        assert (folder / name).read_bytes() == data


# --- the ordinary write ---


def test_both_files_are_replaced_and_nothing_else_is_left(tmp_path):
    out = tmp_path / "a" / "b"
    write_run(out, {"engine.rrd": b"\x00rrd", "metrics.json": "{}\n"})
    assert listing(out) == ["engine.rrd", "metrics.json"]
    assert (out / "engine.rrd").read_bytes() == b"\x00rrd" and (out / "metrics.json").read_text() == "{}\n"
    mask = os.umask(0)
    os.umask(mask)
    assert (out / "metrics.json").stat().st_mode & 0o777 == 0o666 & ~mask  # the usual mode, like any new file


def test_where_folders_cannot_be_opened_the_same_steps_go_by_path(tmp_path, monkeypatch):
    """Windows has no flock and no dir_fd: there the writer names files by path. Same promises, minus the lock."""
    monkeypatch.setattr(outputs, "BY_FOLDER", False)
    out = tmp_path / "out"
    write_run(out / "new", {"engine.rrd": b"rrd", "metrics.json": "{}\n"})
    assert listing(out / "new") == sorted(PAIR) and (out / "new" / "engine.rrd").read_bytes() == b"rrd"
    before = previous_pair(out)
    (out / "metrics.json.partial").symlink_to(tmp_path / "victim")
    (out / "engine.rrd").unlink()
    (out / "engine.rrd").mkdir()
    with pytest.raises(OutputError) as failure:
        write_run(out, {"engine.rrd": b"new", "metrics.json": b"new"})
    assert failure.value.exit_code == 2 and (out / "metrics.json").read_bytes() == before["metrics.json"]
    assert listing(out) == sorted([*PAIR, "metrics.json.partial", "new"]) and not (tmp_path / "victim").exists()


def test_content_id_is_a_function_of_the_content():
    assert content_id('{"a": 1}\n') == content_id(b'{"a": 1}\n') != content_id('{"a": 2}\n')
    assert len(content_id(b"")) == 16 and int(content_id(b"x"), 16) >= 0


# --- planted symlinks ---


def test_a_planted_symlink_is_never_followed(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    out = tmp_path / "out"
    out.mkdir()
    # every name the old writer used, and the final names themselves
    for name in ("metrics.json.partial", "engine.rrd.partial", "metrics.json"):
        (out / name).symlink_to(victim)
    write_run(out, {"engine.rrd": b"new rrd", "metrics.json": b"new metrics"})
    assert victim.read_text() == "precious\n"
    assert not (out / "metrics.json").is_symlink() and (out / "metrics.json").read_bytes() == b"new metrics"


def test_a_symlink_planted_at_the_exact_temporary_name_is_refused(tmp_path, monkeypatch):
    """Even an attacker who guessed the random name only makes the write fail (O_EXCL | O_NOFOLLOW)."""
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    out = tmp_path / "out"
    before = previous_pair(out)
    monkeypatch.setattr(outputs.secrets, "token_hex", lambda n: "guessed")
    (out / ".engine.rrd.guessed.tmp").symlink_to(victim)
    with pytest.raises(OutputError) as failure:
        write_run(out, {"engine.rrd": b"new rrd", "metrics.json": b"new metrics"})
    assert failure.value.exit_code == 1 and "left as they were" in str(failure.value)
    assert victim.read_text() == "precious\n"
    (out / ".engine.rrd.guessed.tmp").unlink()
    assert_unchanged(out, before)


# --- a directory in a file's place ---


@pytest.mark.parametrize("name", PAIR)
def test_a_folder_in_a_files_place_is_bad_input_and_nothing_is_replaced(name, tmp_path):
    out = tmp_path / "out"
    before = previous_pair(out)
    (out / name).unlink()
    (out / name).mkdir()
    before.pop(name)
    assert folder_problem(out, PAIR) == f"{out / name} is a folder; move it away or choose another output folder"
    with pytest.raises(OutputError) as failure:
        write_run(out, {"engine.rrd": b"new", "metrics.json": b"new"})
    assert failure.value.exit_code == 2 and str(failure.value).endswith("were left as they were")
    assert listing(out) == sorted(PAIR) and (out / name).is_dir()
    for other, data in before.items():
        assert (out / other).read_bytes() == data


# --- a full disk ---


@contextlib.contextmanager
def small_tmpfs(kib: int):
    """A real, nearly empty file system of `kib` KiB, or a skip if this machine cannot mount one."""
    where = Path(tempfile.mkdtemp(prefix="tmpfs-"))
    mounted = os.geteuid() == 0 and shutil.which("mount") and subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={kib}k", "tmpfs", str(where)], capture_output=True).returncode == 0
    if not mounted:
        where.rmdir()
        pytest.skip("cannot mount a tmpfs here (needs root and CAP_SYS_ADMIN); the injected ENOSPC test covers it")
    try:
        yield where
    finally:
        subprocess.run(["umount", str(where)], check=True)
        where.rmdir()


def test_a_full_disk_is_one_error_and_the_previous_files_survive():
    with small_tmpfs(64) as disk:
        out = disk / "out"
        before = previous_pair(out)
        with pytest.raises(OutputError) as failure:
            write_run(out, {"engine.rrd": os.urandom(256 * 1024), "metrics.json": b"{}\n"})
        message = str(failure.value)
        assert failure.value.exit_code == 1 and "No space left on device" in message and "\n" not in message
        assert message.startswith(f"cannot write {out / 'engine.rrd'}") and message.endswith("left as they were")
        assert_unchanged(out, before)


def test_a_full_disk_for_a_new_folder_leaves_no_empty_folder():
    with small_tmpfs(64) as disk:
        with pytest.raises(OutputError):
            write_run(disk / "new" / "out", {"engine.rrd": os.urandom(256 * 1024), "metrics.json": b"{}\n"})
        assert listing(disk) == []


def test_injected_enospc_halfway_through_is_caught(tmp_path, monkeypatch):
    """Where no tmpfs can be mounted: the OS call itself says ENOSPC after the first 1000 bytes."""
    out = tmp_path / "out"
    before = previous_pair(out)
    real_write, written = os.write, []

    def write_until_full(fd, data):
        if sum(written) >= 1000:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        written.append(real_write(fd, bytes(data[:500])))
        return written[-1]

    monkeypatch.setattr(outputs.os, "write", write_until_full)
    with pytest.raises(OutputError) as failure:
        write_run(out, {"engine.rrd": b"r" * 4000, "metrics.json": b"{}\n"})
    monkeypatch.undo()
    assert "No space left on device" in str(failure.value) and sum(written) == 1000
    assert_unchanged(out, before)


# --- the second rename fails ---


def test_when_the_second_rename_fails_the_message_says_which_file_is_new(tmp_path, monkeypatch):
    """A failure between the two renames (injected at os.rename: EIO) must say exactly which file is new."""
    out = tmp_path / "out"
    previous_pair(out)
    real_rename = os.rename

    def rename_once(src, dst, **kwargs):
        if dst == "metrics.json":
            raise OSError(errno.EIO, os.strerror(errno.EIO))
        return real_rename(src, dst, **kwargs)

    monkeypatch.setattr(outputs.os, "rename", rename_once)
    with pytest.raises(OutputError) as failure:
        write_run(out, {"engine.rrd": b"new rrd", "metrics.json": b"new metrics"})
    monkeypatch.undo()
    assert str(failure.value) == (f"only part of the run was written: engine.rrd in {out} is new, but metrics.json "
                                  "could not be replaced (Input/output error), so metrics.json is from an earlier run")
    assert listing(out) == sorted(PAIR)
    assert (out / "engine.rrd").read_bytes() == b"new rrd" and (out / "metrics.json").read_bytes() == b'{"old": true}\n'


def test_a_mount_point_in_metrics_place_fails_the_second_rename_for_real(tmp_path):
    """The same failure from the kernel itself: renaming onto a bind-mounted file is EBUSY."""
    with small_tmpfs(64) as disk:
        out = disk / "out"
        previous_pair(out)
        shield = disk / "shield"
        shield.write_text("mounted over metrics.json\n")
        subprocess.run(["mount", "--bind", str(shield), str(out / "metrics.json")], check=True)
        try:
            with pytest.raises(OutputError) as failure:
                write_run(out, {"engine.rrd": b"new rrd", "metrics.json": b"new metrics"})
        finally:
            subprocess.run(["umount", str(out / "metrics.json")], check=True)
        assert str(failure.value).startswith(f"only part of the run was written: engine.rrd in {out} is new, but "
                                             "metrics.json could not be replaced (Device or resource busy)")
        assert listing(out) == sorted(PAIR) and (out / "engine.rrd").read_bytes() == b"new rrd"


# --- writers take turns ---

WRITER = textwrap.dedent("""
    import json, sys
    from curriculum.common.outputs import content_id, write_run
    out, me, rounds = sys.argv[1], sys.argv[2], int(sys.argv[3])
    for n in range(rounds):
        metrics = json.dumps({"writer": me, "round": n}) + "\\n"
        run_id = content_id(metrics)
        # a recording big enough that a write takes a while: ~1 MB tagged with the run id
        write_run(out, {"engine.rrd": (run_id * 65536).encode(), "metrics.json": json.dumps({"run_id": run_id})})
""")


def read_locked(out: Path) -> dict:
    """The pair, read as a reader who wants one run's files takes it: under a shared flock on the folder."""
    fd = os.open(out, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_SH)
        return {name: (out / name).read_bytes() for name in PAIR}
    finally:
        os.close(fd)


def test_concurrent_writers_each_leave_a_whole_pair_and_readers_never_see_a_mix(tmp_path):
    out = tmp_path / "out"
    first = content_id("first")
    write_run(out, {"engine.rrd": (first * 65536).encode(), "metrics.json": json.dumps({"run_id": first})})
    writers = [subprocess.Popen([sys.executable, "-c", WRITER, str(out), str(i), "15"], cwd=REPO,
                                stderr=subprocess.PIPE, text=True) for i in range(4)]
    pairs_seen = 0
    while any(w.poll() is None for w in writers):
        seen = read_locked(out)  # a shared lock: never between a writer's two renames
        run_id = json.loads(seen["metrics.json"])["run_id"]
        assert seen["engine.rrd"] == (run_id * 65536).encode(), "a recording beside another run's metrics"
        pairs_seen += 1
        json.loads((out / "metrics.json").read_text())  # a reader without the lock still sees whole JSON
    for w in writers:
        assert w.wait() == 0 and w.stderr.read() == ""
    final = read_locked(out)
    assert final["engine.rrd"] == (json.loads(final["metrics.json"])["run_id"] * 65536).encode()
    assert listing(out) == sorted(PAIR) and pairs_seen > 0


# --- the check before the run ---


def test_an_out_under_sys_is_refused_in_advance():
    assert folder_problem(Path("/sys/kernel/ch3.3-out"), PAIR) is not None
    assert not Path("/sys/kernel/ch3.3-out").exists()


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc")
@pytest.mark.parametrize("out", ["/proc", "/proc/ch3.3-out/deeper"])
def test_an_out_in_proc_says_the_folder_takes_no_files_not_that_it_is_missing(out):
    assert folder_problem(Path(out), PAIR) == (f"cannot create a file in {out}: /proc exists but does not let"
                                               " files or folders be created in it")


def test_symlinks_as_out_that_lead_nowhere_are_named(tmp_path):
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    (tmp_path / "loop").symlink_to(tmp_path / "loop")
    assert folder_problem(tmp_path / "dangling") == (f"{tmp_path / 'dangling'} cannot be used: {tmp_path / 'dangling'}"
                                                     f" is a symbolic link to {tmp_path / 'nowhere'}, which does not "
                                                     "exist")
    loop = folder_problem(tmp_path / "loop")
    assert loop == f"{tmp_path / 'loop'} cannot be used: it goes through a symbolic link that loops"
    assert listing(tmp_path) == ["dangling", "loop"]


def test_a_300_character_name_is_refused_and_no_folder_is_left(tmp_path):
    problem = folder_problem(tmp_path / "new" / ("x" * 300) / "out")
    assert "a name in it is 300 characters, longer than the file system allows (255)" in problem
    assert listing(tmp_path) == []


def test_the_check_tries_and_leaves_no_trace(tmp_path):
    assert folder_problem(tmp_path / "a" / "b" / "c", PAIR) is None
    assert listing(tmp_path) == []
    (tmp_path / "file").write_text("x")
    assert folder_problem(tmp_path / "file" / "sub") == f"{tmp_path / 'file' / 'sub'} cannot hold files: " \
                                                        f"{tmp_path / 'file'} is a file"


# --- permissions, as a real unprivileged user ---

CHECK = "import sys; from pathlib import Path; from curriculum.common.outputs import folder_problem\n" \
        "assert os.geteuid() != 0 and not os.access('/root', os.R_OK)\n" \
        "print(folder_problem(Path(sys.argv[1]), ['engine.rrd', 'metrics.json']))"


def test_a_read_only_folder_is_refused_for_an_unprivileged_user(shared_tmp):
    (shared_tmp / "ro").mkdir(mode=0o755)  # root's, not writable by nobody
    result = as_nobody(CHECK, shared_tmp / "ro" / "out")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == f"cannot create a file in {shared_tmp / 'ro' / 'out'}: Permission denied"
    assert listing(shared_tmp / "ro") == []


def test_someone_elses_file_in_a_sticky_folder_is_refused_in_advance(shared_tmp):
    sticky = shared_tmp / "sticky"
    sticky.mkdir()
    sticky.chmod(0o1777)  # like /tmp, owned by root
    (sticky / "metrics.json").write_text("root's\n")  # owned by root too
    result = as_nobody(CHECK, sticky)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == (f"{sticky / 'metrics.json'} belongs to another user in a sticky folder "
                                     "(like /tmp), so it cannot be replaced; choose another output folder")
    # and had we gone ahead anyway: the rename fails, one line, no temporary file left
    write = "import sys; from curriculum.common.outputs import write_run, OutputError\n" \
            "try: write_run(sys.argv[1], {'engine.rrd': b'r', 'metrics.json': b'm'})\n" \
            "except OutputError as e: print(e.exit_code, e)"
    result = as_nobody(write, sticky)
    assert result.stdout.startswith("2 ") and "sticky" in result.stdout and result.stderr == ""
    assert listing(sticky) == ["metrics.json"] and (sticky / "metrics.json").read_text() == "root's\n"


# --- signals while writing ---

SIGNALLED = textwrap.dedent("""
    import os, signal, sys
    from curriculum.common import outputs
    out, signame, at = sys.argv[1], sys.argv[2], sys.argv[3]
    real = getattr(os, at)
    def signal_self_once(*args, **kwargs):  # the signal lands at this exact moment of the write
        setattr(outputs.os, at, real)
        result = real(*args, **kwargs)
        os.kill(os.getpid(), getattr(signal, signame))
        return result
    setattr(outputs.os, at, signal_self_once)

    @outputs.one_line_failures("writer")
    def main():
        outputs.write_run(out, {"engine.rrd": b"new rrd" * 100000, "metrics.json": b"new metrics"})
        print("finished")
        return 0
    sys.exit(main())
""")


@pytest.mark.parametrize("signame, code", [("SIGINT", 130), ("SIGTERM", 143)])
@pytest.mark.parametrize("at", ["open", "write", "fsync"])
def test_a_signal_while_the_temporary_files_are_written_removes_them(signame, code, at, tmp_path):
    out = tmp_path / "out"
    before = previous_pair(out)
    result = subprocess.run([sys.executable, "-c", SIGNALLED, str(out), signame, at], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == code and result.stdout == ""
    word = "interrupted" if signame == "SIGINT" else "terminated"
    assert result.stderr == f"{word}: engine.rrd and metrics.json in {out} were left as they were\n"
    assert_unchanged(out, before)


@pytest.mark.parametrize("signame, code", [("SIGINT", 130), ("SIGTERM", 143)])
def test_a_signal_between_the_renames_waits_until_the_pair_is_whole(signame, code, tmp_path):
    out = tmp_path / "out"
    previous_pair(out)
    result = subprocess.run([sys.executable, "-c", SIGNALLED, str(out), signame, "rename"], cwd=REPO,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == code and result.stdout == ""
    assert result.stderr.endswith(f": engine.rrd and metrics.json in {out} were written before that\n")
    assert listing(out) == sorted(PAIR) and (out / "metrics.json").read_bytes() == b"new metrics"


def test_signals_are_held_only_inside_the_critical_section():
    with pytest.raises(KeyboardInterrupt):
        with outputs.signals_held():
            os.kill(os.getpid(), signal.SIGINT)
            held = True  # reached: the signal waited
    assert held and signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_importing_the_writer_installs_no_handler():
    code = "import signal; before = signal.getsignal(signal.SIGTERM); import curriculum.common.outputs; " \
           "print(before is signal.getsignal(signal.SIGTERM) is signal.SIG_DFL)"
    result = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True)
    assert result.stdout == "True\n"


# === engine.py as a student runs it: the same guarantees end to end ===

ENGINE = REPO / "engine.py"


def engine(*args, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ENGINE), *map(str, args)], cwd=kwargs.pop("cwd", REPO),
                          capture_output=True, text=True, timeout=kwargs.pop("timeout", 120), **kwargs)


def recording_id(path: Path) -> str:
    rerun_chunk = pytest.importorskip("rerun.chunk")
    (recording,) = rerun_chunk.RrdReader(path).recordings()
    return recording.recording_id


def assert_one_line(result, code: int, *words: str) -> None:
    assert result.returncode == code, (result.returncode, result.stderr)
    assert len(result.stderr.splitlines()) == 1 and "Traceback" not in result.stderr, result.stderr
    for word in words:
        assert word in result.stderr, result.stderr


def test_both_files_carry_one_run_id_and_metrics_stay_deterministic(tmp_path):
    assert engine("--smoke", "--out", tmp_path / "a").returncode == 0
    assert engine("--smoke", "--out", tmp_path / "b").returncode == 0
    text = (tmp_path / "a" / "metrics.json").read_text()
    assert text == (tmp_path / "b" / "metrics.json").read_text()  # same flags, same bytes
    metrics = json.loads(text)
    run_id = metrics.pop("run_id")
    assert run_id == content_id(json.dumps(metrics, indent=2, sort_keys=True) + "\n")  # anyone can recompute it
    assert recording_id(tmp_path / "a" / "engine.rrd") == run_id


def test_concurrent_runs_into_one_folder_each_leave_a_pair_from_one_run(tmp_path):
    out = tmp_path / "out"
    runs = [subprocess.Popen([sys.executable, str(ENGINE), "--smoke", "--seed", str(seed), "--out", str(out)],
                             cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for seed in range(4)]
    for run in runs:
        _, stderr = run.communicate(timeout=120)
        assert run.returncode == 0 and stderr == ""
    assert listing(out) == sorted(PAIR)
    metrics = json.loads((out / "metrics.json").read_text())
    assert recording_id(out / "engine.rrd") == metrics["run_id"] and metrics["seed"] in range(4)


def test_engine_on_a_full_disk_is_one_line_and_keeps_the_previous_pair():
    with small_tmpfs(96) as disk:
        out = disk / "out"
        before = previous_pair(out)
        result = engine("--smoke", "--out", out)  # the recording is ~130 KB: it cannot fit
        assert_one_line(result, 1, "No space left on device", "were left as they were")
        assert_unchanged(out, before)
        fill(disk)  # --no-rerun on a disk with no byte left: metrics.json alone cannot be written
        result = engine("--smoke", "--no-rerun", "--out", out)
        assert_one_line(result, 1, "No space left on device")
        assert_unchanged(out, before)


def fill(disk: Path) -> None:
    with contextlib.suppress(OSError), open(disk / "filler", "wb", buffering=0) as filler:
        while True:
            filler.write(b"\0" * 4096)


def test_engine_never_writes_through_a_planted_symlink(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("precious\n")
    out = tmp_path / "out"
    out.mkdir()
    for name in ("metrics.json.partial", "engine.rrd.partial"):
        (out / name).symlink_to(victim)
    assert engine("--smoke", "--out", out).returncode == 0
    assert victim.read_text() == "precious\n"
    assert listing(out) == sorted([*PAIR, "metrics.json.partial", "engine.rrd.partial"])


LONG_NAME = "x" * 300
BAD_OUT = {
    "under /sys": ("/sys/kernel/ch3.3-out", "/sys/kernel/ch3.3-out"),
    "dangling symlink": ("dangling", "is a symbolic link to nowhere, which does not exist"),
    "looping symlink": ("loop", "a symbolic link that loops"),
    "300-character name": (f"new/{LONG_NAME}/out", "a name in it is 300 characters"),
    "metrics.json is a folder": ("taken", "metrics.json is a folder"),
    "engine.rrd is a folder": ("taken-rrd", "engine.rrd is a folder"),
    "empty": ("", "the output folder is empty"),
}


@pytest.mark.parametrize("case", BAD_OUT)
def test_an_out_that_cannot_take_the_files_is_bad_input_found_before_the_run(case, tmp_path):
    out, words = BAD_OUT[case]
    (tmp_path / "dangling").symlink_to("nowhere")
    (tmp_path / "loop").symlink_to("loop")
    (tmp_path / "taken" / "metrics.json").mkdir(parents=True)
    (tmp_path / "taken-rrd" / "engine.rrd").mkdir(parents=True)
    before = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*"))
    result = engine("--steps", "10000000", "--out", out, cwd=tmp_path, timeout=30)  # found before 10 M steps
    assert_one_line(result, 2, "--out", words)
    assert result.stdout == ""
    assert sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*")) == before  # nothing created


def test_an_unwritable_out_is_bad_input_for_an_unprivileged_user(shared_tmp):
    (shared_tmp / "ro").mkdir(mode=0o755)
    code = "import sys; sys.exit(engine.main(['--smoke', '--no-rerun', '--out', sys.argv[1]]))"
    loaded = "import engine, numpy.random, gettext, locale, shutil, textwrap"  # what argparse loads lazily
    result = as_nobody(code, shared_tmp / "ro" / "out", load=loaded)
    assert_one_line(result, 2, "--out", "Permission denied")
    assert listing(shared_tmp / "ro") == []


def test_a_broken_rerun_install_is_one_line_before_anything_is_made(tmp_path):
    fake = tmp_path / "site" / "rerun"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("from rerun_bindings import a_name_this_build_lacks\n")  # a half-installed SDK
    result = engine("--out", tmp_path / "out", env={**os.environ, "PYTHONPATH": str(tmp_path / "site")})
    assert_one_line(result, 2, "rerun-sdk is installed but does not import", "--no-rerun")
    assert result.stdout == "" and listing(tmp_path) == ["site"]


def test_out_of_memory_at_the_step_cap_is_one_line(tmp_path):
    import resource

    code = "import re, engine; print(re.search(r'VmSize:\\s+(\\d+)', open('/proc/self/status').read()).group(1))"
    loaded = int(subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True).stdout)
    limit = loaded * 1024 + 30 * 2**20  # what the imports need and 30 MB: less than one 80 MB energy history

    def limit_memory():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    result = engine("--steps", "10000000", "--integrator", "euler", "--no-rerun", "--out", tmp_path / "out",
                    preexec_fn=limit_memory)
    assert_one_line(result, 1, "not enough memory", "no file was written")
    assert listing(tmp_path) == []


# --- stdout closed or full ---


def test_stdout_closed_early_is_one_line_and_the_files_are_whole(tmp_path):
    run = subprocess.Popen([sys.executable, str(ENGINE), "--smoke", "--out", str(tmp_path)], cwd=REPO,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert run.stdout.readline().startswith("[ch3.3-engine]")  # like `| head -1`
    run.stdout.close()
    stderr = run.stderr.read()
    assert run.wait(timeout=120) == 1
    assert stderr.splitlines() == [f"engine.py: error: could not print the report (Broken pipe: stdout closed or "
                                   f"full?); engine.rrd and metrics.json in {tmp_path} were written before that"]
    assert recording_id(tmp_path / "engine.rrd") == json.loads((tmp_path / "metrics.json").read_text())["run_id"]


def test_a_full_stdout_is_one_line_and_nothing_is_written(tmp_path):
    with open("/dev/full", "w") as full:
        result = subprocess.run([sys.executable, str(ENGINE), "--smoke", "--no-rerun", "--out", str(tmp_path / "o")],
                                cwd=REPO, stdout=full, stderr=subprocess.PIPE, text=True, timeout=120)
    assert result.returncode == 1
    assert result.stderr == "engine.py: error: could not print the report (No space left on device: stdout closed " \
                            "or full?); no file was written\n"
    assert listing(tmp_path) == []


# --- signals during a run ---


def test_sigterm_during_the_simulation_exits_143_and_keeps_the_previous_pair(tmp_path):
    before = previous_pair(tmp_path)
    flags = ["--steps", "2000000", "--integrator", "euler", "--no-rerun", "--out", str(tmp_path)]
    run = subprocess.Popen([sys.executable, str(ENGINE), *flags], cwd=REPO, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    while run.stderr.read(1) != "%":  # its first progress report: integrating
        pass
    run.terminate()
    _, stderr = run.communicate(timeout=60)
    assert run.returncode == 143 and stderr.splitlines()[-1] == "terminated: no file was written"
    assert_unchanged(tmp_path, before)


def test_a_run_waits_its_turn_for_the_folder_and_sigterm_still_ends_it(tmp_path):
    """Another writer holds the folder's lock: the run waits (it does not write between that writer's
    renames), and waiting is no hang: SIGTERM ends it at once with one line."""
    import fcntl

    before = previous_pair(tmp_path)
    holder = os.open(tmp_path, os.O_RDONLY | os.O_DIRECTORY)
    fcntl.flock(holder, fcntl.LOCK_EX)
    try:
        run = subprocess.Popen([sys.executable, str(ENGINE), "--smoke", "--no-rerun", "--out", str(tmp_path)],
                               cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert run.stdout.readline().startswith("[ch3.3-engine]")
        with pytest.raises(subprocess.TimeoutExpired):
            run.wait(timeout=1.5)  # a --no-rerun smoke run takes a fraction of that: it is waiting for the lock
        run.terminate()
        _, stderr = run.communicate(timeout=30)
    finally:
        os.close(holder)
    assert run.returncode == 143
    assert stderr == f"terminated: {tmp_path / 'metrics.json'} was left as it was\n"
    assert_unchanged(tmp_path, before)


AT_A_MOMENT = textwrap.dedent("""
    import os, signal, sys
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

MOMENTS = {  # where the signal lands -> what the one line says about the files
    "while the recording is built": ("engine_recording", "log_curves", "no file was written"),
    "while the recording is written": ("os", "write", "engine.rrd and metrics.json in {out} were left as they were"),
    "while it is flushed to disk": ("os", "fsync", "engine.rrd and metrics.json in {out} were left as they were"),
    "between the two renames": ("os", "rename", "engine.rrd and metrics.json in {out} were written before that"),
}


@pytest.mark.parametrize("signame, code, word", [("SIGINT", 130, "interrupted"), ("SIGTERM", 143, "terminated")])
@pytest.mark.parametrize("moment", MOMENTS)
def test_a_signal_at_any_moment_leaves_a_whole_pair_and_one_line(signame, code, word, moment, tmp_path):
    where, attribute, said = MOMENTS[moment]
    before = previous_pair(tmp_path)
    result = subprocess.run([sys.executable, "-c", AT_A_MOMENT, signame, where, attribute, str(tmp_path)], cwd=REPO,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == code and result.stderr == f"{word}: {said.format(out=tmp_path)}\n"
    assert listing(tmp_path) == sorted(PAIR)  # no temporary file left
    if "written before" in said:
        metrics = json.loads((tmp_path / "metrics.json").read_text())
        assert recording_id(tmp_path / "engine.rrd") == metrics["run_id"]
    else:
        assert_unchanged(tmp_path, before)


def test_ctrl_c_while_numpy_loads_is_one_line(tmp_path):
    """The signal lands inside `import numpy` (a finder on sys.meta_path sends it), with engine.py run as a script."""
    code = textwrap.dedent("""
        import os, runpy, signal, sys
        class CtrlCOnNumpy:
            def find_spec(self, name, path=None, target=None):
                if name == "numpy":
                    os.kill(os.getpid(), signal.SIGINT)
        sys.meta_path.insert(0, CtrlCOnNumpy())
        sys.argv = ["engine.py", "--smoke", "--out", sys.argv[1]]
        runpy.run_path("engine.py", run_name="__main__")
    """)
    result = subprocess.run([sys.executable, "-c", code, str(tmp_path / "out")], cwd=REPO, capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 130 and result.stderr == "interrupted: no file was written\n"
    assert listing(tmp_path) == []


def test_importing_engine_installs_no_handler_and_main_restores_them(tmp_path):
    code = textwrap.dedent("""
        import signal, sys
        before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
        import engine
        imported = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
        engine.main(["--smoke", "--no-rerun", "--out", sys.argv[1]])
        after = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
        print(before == imported == after)
    """)
    result = subprocess.run([sys.executable, "-c", code, str(tmp_path)], cwd=REPO, capture_output=True, text=True)
    assert result.stdout.splitlines()[-1] == "True", result.stderr


# --- the numbers at the edges ---


def run_here(capsys, *args) -> tuple:
    """engine.main(args) in this process with every warning an error: (exit code, stdout, stderr)."""
    import warnings

    import engine as chapter

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        code = chapter.main([str(arg) for arg in args])
    printed = capsys.readouterr()
    return code, printed.out, printed.err


def strict_json(path: Path) -> dict:
    return json.loads(path.read_text(), parse_constant=lambda constant: pytest.fail(f"{constant} in {path}"))


def test_finite_energies_whose_drift_overflows_are_reported_as_diverged(tmp_path, capsys):
    code, out, err = run_here(capsys, "--dt", "1.33e154", "--steps", "1", "--no-rerun", "--out", tmp_path)
    assert code == 0 and err == ""  # a RuntimeWarning would have raised
    metrics = strict_json(tmp_path / "metrics.json")
    for name in ("euler", "semi_implicit"):
        assert metrics["drift"][name]["diverged"] and metrics["drift"][name]["energy_overflow_step"] == 1
    assert "diverged: energy overflowed at step 1" in out and "cannot judge" in out


@pytest.mark.parametrize("members", [3, 4])  # an odd and an even count: the median of two values can overflow
def test_an_ensemble_whose_drifts_overflow_counts_them_as_diverged(members, tmp_path, capsys):
    code, _, err = run_here(capsys, "--ensemble", members, "--dt", "1.33e154", "--steps", "1", "--out", tmp_path)
    assert code == 0 and err == ""
    block = strict_json(tmp_path / "metrics.json")["ensemble"]
    single = engine_drift_of_each_seed(members)
    assert {name: drift["diverged"] for name, drift in block["drift"].items()} == \
           {name: sum(flags) for name, flags in single.items()}
    assert single["euler"][0]  # seed 0's euler: finite energies whose relative error overflows


def engine_drift_of_each_seed(members: int) -> dict:
    """{integrator: [diverged per seed]} from energy_drift() of single runs: what the ensemble must agree with."""
    import engine as chapter

    return {name: [chapter.energy_drift(run_alone("orbit", name, dt=1.33e154, steps=1, seed=seed)[2])["diverged"]
                   for seed in range(members)]
            for name in chapter.integrators_for(chapter.build_system("orbit", chapter.np.random.default_rng(0)))}


def test_the_verdict_cannot_judge_when_semi_implicit_left_its_band(tmp_path, capsys):
    code, out, err = run_here(capsys, "--dt", "2", "--no-rerun", "--out", tmp_path)
    assert code == 0 and err == ""
    semi = strict_json(tmp_path / "metrics.json")["drift"]["semi_implicit"]
    assert not semi["diverged"] and semi["rel_max"] > 1.0
    assert out.splitlines()[-3].endswith(f"cannot judge, semi_implicit left its band (rel_max {semi['rel_max']:.3g}; "
                                         "try a smaller --dt)")


@pytest.mark.parametrize("flags", [["--dt", "1e-300", "--steps", "3"], ["--dt", "1e-9", "--steps", "10"]])
def test_the_verdict_cannot_judge_drifts_that_are_all_round_off(flags, tmp_path, capsys):
    """Not 'UNEXPECTED': a run too short to drift (or one that did not move at all) has no ordering to judge."""
    code, out, _ = run_here(capsys, *flags, "--no-rerun", "--out", tmp_path)
    assert code == 0
    assert out.splitlines()[-3].endswith("cannot judge, every drift is round-off (more --steps or a larger --dt)")
    assert "as expected" in run_here(capsys, "--dt", "1e-6", "--steps", "100", "--no-rerun", "--out", tmp_path)[1]


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


# --- runs started together into folders that do not exist yet ---


def start_together(commands: list, folder: Path) -> list:
    """Start every command at one instant: each waits in a shell for a go-file, then becomes the command."""
    go = folder / "go"
    runs = [subprocess.Popen(["sh", "-c", 'until [ -e "$0" ]; do sleep 0.005; done; exec "$@"', str(go), *command],
                             cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            for command in commands]
    time.sleep(0.5)  # every shell is waiting
    go.touch()
    return [(run.wait(timeout=300), run.stderr.read()) for run in runs]


def nested(trial: Path, seed: int) -> Path:
    """Four folders, each inside the one before: the runs race to create the same parents."""
    return trial.joinpath(*["x", "sub", "deeper", "deepest"][: seed % 4 + 1])


def assert_each_folder_holds_one_of_its_runs(trial: Path, seeds) -> None:
    for depth in range(4):
        out = nested(trial, depth)
        expected = ["metrics.json"] + (["sub", "deeper", "deepest"][depth:depth + 1])
        assert listing(out) == sorted(expected), f"a probe, a temporary file or a stray folder in {out}"
        seed = json.loads((out / "metrics.json").read_text())["seed"]
        assert seed in seeds and seed % 4 == depth


def concurrent_engine_runs(tmp_path: Path, trials: int, runs: int = 20) -> None:
    (tmp_path / "gates").mkdir()
    for trial in range(trials):
        folder = tmp_path / f"trial{trial}"
        if trial % 2:
            (folder / "x").mkdir(parents=True)  # half the trials: the outermost folder exists already
        gate = tmp_path / "gates" / str(trial)
        gate.mkdir()
        seeds = range(trial * runs, (trial + 1) * runs)
        results = start_together([[sys.executable, "engine.py", "--smoke", "--no-rerun", "--seed", str(seed),
                                   "--out", str(nested(folder, seed))] for seed in seeds], gate)
        assert results == [(0, "")] * runs, [result for result in results if result != (0, "")][:3]
        assert_each_folder_holds_one_of_its_runs(folder, seeds)


def test_twenty_runs_started_together_into_missing_nested_folders_all_succeed_many_times(tmp_path):
    """The issue's case, ten times: 20 real `python engine.py` processes at one instant, into four nested
    folders that do not exist yet (in half the trials the outermost does): 200 runs, every one must succeed."""
    concurrent_engine_runs(tmp_path, trials=10)


CHECK_THEN_WRITE = textwrap.dedent("""
    import os, sys, time
    from pathlib import Path
    from curriculum.common.outputs import OutputError, folder_problem, write_run
    base, me, rounds = Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    while not (base / "go").exists():
        time.sleep(0.001)
    lost = []
    for i in range(rounds):
        out = base / str(i) / "a" / ("b" if me % 2 else "")
        problem = folder_problem(out, ["engine.rrd", "metrics.json"])
        try:
            if problem is None:
                write_run(out, {"engine.rrd": b"r", "metrics.json": f"{me}"})
        except OutputError as error:
            problem = str(error)
        if problem:
            lost.append(f"{i}: {problem}")
    print(len(lost), *lost[:3], sep="\\n")
""")


def test_check_then_write_in_eight_processes_loses_no_run(tmp_path):
    """The issue's replay: 8 processes each check, then write, 300 fresh nested folders at once (2,400 runs).
    Before, the check made the folders and removed them again under the others: 99 of 2,400 lost."""
    writers = [subprocess.Popen([sys.executable, "-c", CHECK_THEN_WRITE, str(tmp_path), str(me), "300"], cwd=REPO,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for me in range(8)]
    time.sleep(0.5)
    (tmp_path / "go").touch()
    for writer in writers:
        stdout, stderr = writer.communicate(timeout=300)
        assert writer.returncode == 0 and stderr == "" and stdout.splitlines()[0] == "0", stdout


def test_a_run_waiting_for_a_folder_that_its_maker_removes_makes_it_again(tmp_path):
    """A run whose write failed removes the folders it made, under their lock; a run that was waiting for
    that lock finds the folder gone (still open, but unlinked) and makes it anew instead of failing."""
    out = tmp_path / "new"
    out.mkdir()
    holder = os.open(out, os.O_RDONLY | os.O_DIRECTORY)
    fcntl = pytest.importorskip("fcntl")
    fcntl.flock(holder, fcntl.LOCK_EX)  # as the failing run holds it
    code = "import sys; from curriculum.common.outputs import write_run; write_run(sys.argv[1], {'metrics.json': '{}'})"
    writer = subprocess.Popen([sys.executable, "-c", code, str(out)], cwd=REPO, stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(1.0)  # the writer has opened the folder and waits for the lock
        os.rmdir(out)  # the failing run removes the folder it had made
    finally:
        os.close(holder)
    assert writer.wait(timeout=60) == 0 and writer.stderr.read() == ""
    assert listing(out) == ["metrics.json"]


# --- file attributes, memory limits ---


def chattr(flag: str, path: Path) -> None:
    if not shutil.which("chattr") or subprocess.run(["chattr", flag, str(path)], capture_output=True).returncode:
        pytest.skip("chattr is missing, or this file system or user cannot set attributes")


def test_an_immutable_metrics_json_is_refused_before_the_run_and_the_pair_stays_whole(tmp_path):
    """Before, engine.rrd was replaced and metrics.json could not be: a new recording beside the old metrics."""
    assert engine("--smoke", "--out", tmp_path).returncode == 0
    before = {name: (tmp_path / name).read_bytes() for name in PAIR}
    chattr("+i", tmp_path / "metrics.json")
    try:
        result = engine("--smoke", "--seed", "1", "--out", tmp_path)
    finally:
        subprocess.run(["chattr", "-i", str(tmp_path / "metrics.json")], check=True)
    assert_one_line(result, 2, "--out", "metrics.json is immutable (chattr +i)")
    assert_unchanged(tmp_path, before)


def test_an_append_only_folder_is_refused_and_keeps_no_probe(tmp_path):
    """In a chattr +a folder a file can be made but never removed: the check's probe used to stay behind."""
    out = tmp_path / "out"
    out.mkdir()
    chattr("+a", out)
    try:
        result = engine("--smoke", "--out", out)
        listed = listing(out)
    finally:
        subprocess.run(["chattr", "-a", str(out)], check=True)
    assert_one_line(result, 2, "--out", "is append-only (chattr +a)")
    assert listed == []


def test_a_path_longer_than_the_system_takes_is_named_as_such_not_as_a_long_name(tmp_path):
    out = tmp_path.joinpath(*["y" * 199] * 25)  # every name 199 characters, the whole path over 5,000
    result = engine("--smoke", "--no-rerun", "--out", out)
    assert_one_line(result, 2, "--out", "the path is", "though no name in it is too long")
    assert listing(tmp_path) == []


def with_memory_limit(megabytes: int):
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (megabytes * 2**20, megabytes * 2**20))

    return limit


@pytest.mark.parametrize("megabytes, flags", [(600, []), (1500, []), (145, ["--no-rerun"])])
def test_a_memory_limit_is_not_enough_memory_never_reinstall(megabytes, flags, tmp_path):
    """ulimit -v 600000 failed in numpy.random's lazy import with a traceback; 1.5 GB blamed the install."""
    result = engine("--smoke", *flags, "--out", tmp_path / "out", preexec_fn=with_memory_limit(megabytes))
    if result.returncode == 0:
        pytest.skip(f"{megabytes} MB is enough on this machine")
    assert "Traceback" not in result.stderr and "reinstall" not in result.stderr, result.stderr
    if result.returncode == -signal.SIGABRT:  # Rerun's Rust code aborts: a known limit (docs/DEVELOPING.md)
        assert re.match(r"memory allocation of \d+ bytes failed\n", result.stderr), result.stderr
    else:  # jemalloc, Rerun's allocator, may say from C that it could not start a thread: not ours to silence
        ours = [line for line in result.stderr.splitlines() if not line.startswith("<jemalloc>")]
        assert len(ours) == 1 and "not enough memory" in ours[0], result.stderr
    assert not (tmp_path / "out").exists()


def test_a_memory_limit_too_small_for_numpy_is_one_line(tmp_path):
    """Below what numpy needs to import at all, the guard's exit hook answers, before main() exists."""
    result = engine("--smoke", "--no-rerun", "--out", tmp_path / "out", preexec_fn=with_memory_limit(40))
    assert result.returncode == 1 and "reinstall" not in result.stderr and "Traceback" not in result.stderr
    assert result.stderr in ("engine.py: error: not enough memory to start (failed to map segment); raise the memory"
                             " limit (ulimit -v) or close other programs, and run it again\n",
                             "engine.py: error: not enough memory to start (MemoryError); raise the memory"
                             " limit (ulimit -v) or close other programs, and run it again\n")


# --- issue 27: another user's symlink, a shared folder, a folder that cannot be read, a flickering parent ---

OTHER_USER = 65533  # any uid but ours and nobody's: the user who plants the link


def planted_link(tmp_path: Path) -> tuple:
    """A sticky folder everyone may write to (like /tmp), where another user made `out` -> a folder of theirs
    holding a metrics.json and an engine.rrd. (Linux's fs.protected_symlinks, off here, would refuse it.)"""
    if os.geteuid() != 0:
        pytest.skip("making a link that belongs to another user needs root")
    shared, theirs = tmp_path / "shared", tmp_path / "theirs"
    shared.mkdir()
    shared.chmod(0o1777)
    (theirs / "deeper").mkdir(parents=True)
    for name in PAIR:
        (theirs / name).write_text("theirs\n")
    (shared / "out").symlink_to(theirs)
    for path in (theirs, theirs / "deeper", *(theirs / name for name in PAIR), shared / "out"):
        os.lchown(path, OTHER_USER, OTHER_USER)
    return shared, theirs


@pytest.mark.parametrize("flags, out", [([], "shared/out"), (["--no-rerun"], "shared/out"),
                                        (["--no-rerun"], "shared/out/deeper"), (["--no-rerun"], "mine")])
def test_a_symlink_another_user_planted_in_a_shared_folder_is_never_followed(flags, out, tmp_path):
    """Before, the run exited 0 and replaced the other user's files; `mine` is our own link leading to theirs."""
    shared, theirs = planted_link(tmp_path)
    (tmp_path / "mine").symlink_to(shared / "out")
    result = engine("--smoke", *flags, "--out", tmp_path / out)
    assert_one_line(result, 2, "--out", f"goes through {shared / 'out'}, a symbolic link that user {OTHER_USER} made")
    assert [(theirs / name).read_text() for name in PAIR] == ["theirs\n"] * 2 and listing(theirs) == ["deeper", *PAIR]
    assert listing(theirs / "deeper") == []


def test_a_link_planted_after_the_check_is_refused_by_the_writer_too(tmp_path):
    shared, theirs = planted_link(tmp_path)
    assert outputs.folder_problem(shared / "out").startswith(f"{shared / 'out'} goes through")
    with pytest.raises(OutputError) as refused:
        write_run(shared / "out", {"metrics.json": "{}\n"})
    assert refused.value.exit_code == 2 and (theirs / "metrics.json").read_text() == "theirs\n"


def test_our_own_link_in_a_shared_folder_is_followed(tmp_path):
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o1777)
    (tmp_path / "mine").mkdir()
    (shared / "out").symlink_to(tmp_path / "mine")
    assert engine("--smoke", "--no-rerun", "--out", shared / "out").returncode == 0
    assert listing(tmp_path / "mine") == ["metrics.json"]


RACE = textwrap.dedent("""
    import os, sys, time
    import engine, numpy.random, gettext, locale, json, pkgutil, shutil, textwrap
    go, uid = sys.argv[1], int(sys.argv[2])
    os.setgroups([]); os.setgid(uid); os.setuid(uid)
    while not os.path.exists(go):
        time.sleep(0.002)
    sys.exit(engine.main(sys.argv[3:]))
""")


def test_two_users_started_together_into_a_new_shared_folder_never_fail_after_the_run(shared_tmp):
    """The folder gets its creator's umask, so only its creator may write in it. Before, the other user's run
    computed, then failed at the write (exit 1); now the check makes the folder, and the other is refused first."""
    shared = shared_tmp / "shared"
    shared.mkdir()
    shared.chmod(0o1777)
    for trial in range(4):
        go, out = shared_tmp / f"go{trial}", shared / f"run{trial}"
        runs = [subprocess.Popen([sys.executable, "-c", RACE, str(go), str(uid), "--smoke", "--no-rerun", "--out",
                                  str(out)], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                for uid in (NOBODY, OTHER_USER)]
        time.sleep(1.5)  # both have loaded and wait
        go.touch()
        ended = sorted((run.wait(timeout=120), run.stderr.read()) for run in runs)
        assert ended[0] == (0, ""), ended
        assert ended[1] == (0, "") or (ended[1][0] == 2 and ended[1][1].endswith(f"{out}: Permission denied (see"
                                                                                  " --help)\n")), ended


def test_a_folder_that_can_be_written_but_not_read_is_refused_before_the_run(shared_tmp):
    """Mode 333: a file can be made in it, but the writer opens the folder to take its turn. Before: exit 1,
    after the run, with a reason about creating files."""
    (shared_tmp / "wx").mkdir()
    (shared_tmp / "wx").chmod(0o333)
    code = "import sys; sys.exit(engine.main(['--smoke', '--out', sys.argv[1]]))"
    result = as_nobody(code, shared_tmp / "wx", load="import engine, numpy.random, gettext, locale, shutil, textwrap")
    assert_one_line(result, 2, "--out", "wx lets files be made in it but not read (d-wx-wx-wx)")


def test_a_name_that_appears_and_vanishes_at_the_parent_never_raises_from_the_check(tmp_path):
    """Another process makes and removes a file, a folder and a dangling link at --out's parent, over and over;
    the check answers each time, whatever it finds (before: FileNotFoundError from inside the check)."""
    parent, stop = tmp_path / "flicker", tmp_path / "stop"
    toggler = subprocess.Popen([sys.executable, "-c", textwrap.dedent("""
        import os, sys
        parent, stop = sys.argv[1:3]
        while not os.path.exists(stop):
            for make, remove in ((lambda: open(parent, "w").close(), os.unlink), (lambda: os.mkdir(parent), os.rmdir),
                                 (lambda: os.symlink("/nowhere", parent), os.unlink)):
                try:
                    make()
                    remove(parent)
                except OSError:
                    pass
    """), str(parent), str(stop)])
    try:
        answers = {folder_problem(parent / "out", PAIR) is None for _ in range(20_000)}
    finally:
        stop.touch()
        toggler.wait(timeout=30)
    assert answers  # every call returned


# --- issue 27: the run's numbers at the edges, and Rerun's sink dropped by a signal ---


@pytest.mark.parametrize("flags", [["--system", "damped_spring", "--dt", "100", "--damping", "1e6", "--steps", "5"],
                                   ["--system", "damped_spring", "--dt", "1e12", "--steps", "3"],
                                   ["--dt", "1e-320", "--ensemble", "3"]])
def test_overflowing_and_unmoving_runs_write_their_files(flags, tmp_path):
    """numpy's round() of a float64 past 1.8e296 gave inf, which strict JSON refused after the run; an ensemble
    whose every error is log10(0) gave the recording no range to unpack. Both were tracebacks."""
    result = engine(*flags, "--out", tmp_path)
    assert result.returncode == 0 and "Traceback" not in result.stderr, result.stderr
    strict_json(tmp_path / "metrics.json")
    assert recording_id(tmp_path / "engine.rrd") == json.loads((tmp_path / "metrics.json").read_text())["run_id"]


SINK_MOMENT = textwrap.dedent("""
    import os, signal, sys
    import engine, rerun, rerun._memory
    owner = {"stream": rerun.RecordingStream, "memory": rerun._memory.MemoryRecording}[sys.argv[1]]
    attribute, before = sys.argv[2], sys.argv[3] == "before"
    real = getattr(owner, attribute)
    def signal_here(*args, **kwargs):  # SIGTERM lands at this exact moment of building the recording
        setattr(owner, attribute, real)
        if before:
            os.kill(os.getpid(), signal.SIGTERM)
        result = real(*args, **kwargs)
        os.kill(os.getpid(), signal.SIGTERM)
        return result
    setattr(owner, attribute, signal_here)
    sys.exit(engine.main(["--smoke", "--out", sys.argv[4]]))
""")


@pytest.mark.parametrize("moment", [("stream", "memory_recording", "after"), ("memory", "drain_as_bytes", "before")])
def test_sigterm_as_rerun_makes_or_drains_its_sink_is_one_line_and_no_warning(moment, tmp_path):
    """Landing between the sink's making and its draining, SIGTERM left Rerun data to drop: a coloured WARN line."""
    result = subprocess.run([sys.executable, "-c", SINK_MOMENT, *moment, str(tmp_path)], cwd=REPO,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 143 and result.stderr == "terminated: no file was written\n"
    assert listing(tmp_path) == []
