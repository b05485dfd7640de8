#!/usr/bin/python3
"""The examples of docs/tools.md run as written (docs/tools.md#python, #shell-pipelines).

In a temporary folder that sees the repository's tests/, data/ and scenarios/ (symlinks), tests/data/scene.json is run into
out/scene.h5 and exported to out/scene.csv, as the page's examples assume. Then every ```python block of
the page runs with Debian's /usr/bin/python3 (h5py, pandas) and must exit 0, and the first one must print
the swarm orders its comment states; the ```sh block of "Shell pipelines" runs with bash -e (B = the
built swarmsim) and the awk line must count the 550 agents of frame 12. Exit 77 (skipped) without pandas.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

SWARMSIM = os.environ.get("SWARMSIM", "swarmsim")
SRC = os.environ.get("SWARMSIM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def run(cmd, cwd, env=None):
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=240, env=env)
    if p.returncode != 0:
        fail("%s exited %d:\n%s%s" % (" ".join(cmd)[:300], p.returncode, p.stdout[-2000:], p.stderr[-3000:]))
    return p


def blocks(text, lang):
    return re.findall(r"^```%s\n(.*?)^```" % lang, text, flags=re.S | re.M)


def main():
    if subprocess.run(["/usr/bin/python3", "-c", "import pandas"], capture_output=True).returncode != 0:
        print("SKIP: pandas not installed (Debian package python3-pandas; scripts/setup.sh --tools)")
        sys.exit(77)
    with open(os.path.join(SRC, "docs", "tools.md")) as f:
        page = f.read()
    python = blocks(page, "python")
    if len(python) < 2:
        fail("docs/tools.md has %d python blocks, expected at least 2" % len(python))
    shell = re.search(r"^## Shell pipelines\n.*?^```sh\n(.*?)^```", page, flags=re.S | re.M)
    if not shell:
        fail("docs/tools.md: no sh block under 'Shell pipelines'")
    tmp = tempfile.mkdtemp(prefix="swarmsim-docs-")
    try:
        for name in ("tests", "data", "scenarios"):  # tests/data/scene.json names ../../data/street_lamp.obj
            os.symlink(os.path.join(os.path.abspath(SRC), name), os.path.join(tmp, name))
        run([SWARMSIM, "run", "tests/data/scene.json", "-o", "out/scene.h5", "--quiet"], tmp)
        run([SWARMSIM, "export", "out/scene.h5", "--format", "csv", "--quiet"], tmp)
        for k, code in enumerate(python):
            p = run(["/usr/bin/python3", "-c", code], tmp)
            if k == 0 and not p.stdout.startswith("['midges', 'gnats'] ['gnats', 'midges']"):
                fail("the first python block printed %r, its comment says ['midges', 'gnats'] ['gnats', 'midges']"
                     % p.stdout.splitlines()[0])
        env = dict(os.environ, B=SWARMSIM)
        p = run(["bash", "-e", "-o", "pipefail", "-c", shell.group(1)], tmp, env)
        first = p.stdout.split()
        if not first or first[0] != "550":
            fail("the awk example printed %r, expected 550 agents in frame 12" % p.stdout)
        if not os.path.getsize(os.path.join(tmp, "last_gnats.csv")) or \
                not os.path.isfile(os.path.join(tmp, "out", "piped.h5")):
            fail("the shell examples did not write last_gnats.csv and out/piped.h5")
        print("ok: %d python blocks and the shell pipelines of docs/tools.md ran" % len(python))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
