"""Helpers shared by the tests: run engine.py the way a student does."""

import os
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

# A runner may start the suite with Ctrl-C or SIGTERM ignored (a background job of a non-interactive shell is
# started that way); the programs under test keep an ignored signal ignored, on purpose. The signal tests need
# them delivered, to this process and to the children it starts (a handled signal is default again after exec).
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
if signal.getsignal(signal.SIGTERM) is signal.SIG_IGN:
    signal.signal(signal.SIGTERM, signal.SIG_DFL)

REPO = Path(__file__).resolve().parents[1]
ENGINE = REPO / "engine.py"


def run_engine(*args, cwd=None, env=None, timeout=120):
    """`python engine.py ARGS` in a fresh interpreter; returns the CompletedProcess."""
    return subprocess.run([sys.executable, str(ENGINE), *map(str, args)], cwd=cwd or REPO, env=env,
                          capture_output=True, text=True, timeout=timeout)


# --- permissions, as a real unprivileged user ---

NOBODY = 65534


@pytest.fixture
def shared_tmp():
    """A folder an unprivileged user can reach (pytest's tmp_path is private to root)."""
    if os.geteuid() != 0:
        pytest.skip("dropping to an unprivileged user needs root; as a normal user os.access is already honest")
    where = Path(tempfile.mkdtemp(prefix="outputs-perm-"))
    where.chmod(0o755)
    yield where
    shutil.rmtree(where)


def as_nobody(code: str, *args, load: str = "import curriculum.common.outputs") -> subprocess.CompletedProcess:
    """Run `code` as user nobody. The interpreter (under /root, private) starts as root and imports what
    `load` names, then drops every privilege for good before `code` touches a file."""
    drop = f"import os; {load}; os.setgroups([]); os.setgid({NOBODY}); os.setuid({NOBODY})\n"
    return subprocess.run([sys.executable, "-c", drop + code, *map(str, args)], cwd=REPO,
                          capture_output=True, text=True, timeout=60)
