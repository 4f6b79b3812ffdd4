"""Results made once per test run and shared by the test processes (pytest-xdist's
workers): an expensive build that several tests check runs once, not once per test or
per process."""

from __future__ import annotations

import os


def shared_once(tmp_path_factory, name: str, build):
    """A directory made once per test run and shared by every test process:
    ``build(directory)`` fills it the first time (returning a JSON-serialisable value),
    under a lock in the run's common temporary directory (the parent of each
    pytest-xdist worker's own), so a test that another process ran first reads what
    that one built.  Returns ``(directory, value)``.  A build that raised is not
    recorded: the next test to ask builds again (and fails on its own)."""
    import fcntl
    import json

    base = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        base = base.parent  # shared by the workers of this run
    root = base / f"shared-{name}"
    done = base / f"shared-{name}.json"
    with open(base / f"shared-{name}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if done.is_file():
            return root, json.loads(done.read_text())
        if root.exists():  # a build that failed part way
            import shutil

            shutil.rmtree(root)
        root.mkdir(parents=True)
        value = build(root)
        tmp = done.with_suffix(f".tmp{os.getpid()}")
        tmp.write_text(json.dumps(value))
        os.replace(tmp, done)
        return root, value
