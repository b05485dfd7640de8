#!/usr/bin/python3
"""pvbatch renders frames of an XDMF export with scripts/paraview_render.py (docs/tools.md#paraview).

A two-swarm run with three obstacles (tests/data/scene.json) is exported as .xmf2 and two frames are
rendered by ParaView's pvbatch on an Xvfb display of its own: one PNG per frame, named by the HDF5 frame number, of the asked
size; each shows both swarms in their own colours (the two first colours of the script's palette) and the
grey obstacles, and the two frames differ (the insects moved). A range that selects no frame and an output
name without a frame field for several frames are exit 2. Exit 77 (skipped) without pvbatch or Xvfb, or when
ParaView's own OpenGL probe finds no OpenGL window under Xvfb on this machine (twice), with its reasons.
"""
import contextlib
import os
import shutil
import subprocess
import sys
import tempfile

import matplotlib.image
import numpy as np

SWARMSIM = os.environ.get("SWARMSIM", "swarmsim")
SRC = os.environ.get("SWARMSIM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
SCRIPT = os.path.join(SRC, "scripts", "paraview_render.py")
BLUE, ORANGE = (0.12, 0.47, 0.71), (1.0, 0.50, 0.05)


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def run(cmd, cwd, expect=0, env=None):
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=240, env=env)
    if p.returncode != expect and env is not None and "bad X server connection" in p.stdout + p.stderr:
        # the display went away under pvbatch (seen once in CI, after the probe had opened a window on it):
        # that is the X server's fault, not the script's; one more try on a new display, said in the log
        print("note: pvbatch lost its X server (%s); again on a new display" % errors(p.stdout + p.stderr))
        with Xserver(cwd) as x:
            p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=240, env=x.env)
    if p.returncode != expect:
        fail("%s exited %d (expected %d):\n%s\n--- output:\n%s%s" % (" ".join(cmd), p.returncode, expect,
             errors(p.stdout + p.stderr), p.stdout[-1500:], p.stderr[-1500:]))
    return p


class Xserver:
    """An Xvfb on a free display, started by us and ready before we go on (-displayfd writes its number once
    it accepts connections); xvfb-run -a can hand pvbatch a display that is not up yet. -ac: no access
    control, so an XAUTHORITY of the caller's cannot get in the way. Its messages go to a log for diagnosis."""

    def __init__(self, tmp):
        self.log_path = os.path.join(tmp, "xvfb-%d.log" % id(self))

    def __enter__(self):
        r, w = os.pipe()
        with open(self.log_path, "w") as log:
            self.proc = subprocess.Popen(["Xvfb", "-displayfd", str(w), "-screen", "0", "1280x1024x24", "-nolisten",
                                          "tcp", "-ac"], pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=log)
        os.close(w)
        with os.fdopen(r) as f:
            number = f.readline().strip()
        if not number:
            self.proc.kill()
            self.proc.wait()
            fail("Xvfb did not start:\n" + self.log())
        # llvmpipe in the client: Xvfb has no direct rendering, so never try a GPU driver of the machine's
        self.env = dict(os.environ, DISPLAY=":" + number, LIBGL_ALWAYS_SOFTWARE="1")
        return self

    def log(self):
        with open(self.log_path, errors="replace") as f:
            return f.read()[-1500:]

    def __exit__(self, *exc):
        self.proc.terminate()
        self.proc.wait()


def errors(text):
    """VTK's error lines (ERR|), ahead of the long stack trace that follows an abort"""
    return "\n".join(line.strip() for line in text.splitlines() if "ERR|" in line or "Aborting" in line)[-1500:]


@contextlib.contextmanager
def opengl_display(tmp):
    """An Xvfb on which VTK gets an OpenGL window, checked with ParaView's own probe
    (vtkProbeOpenGLVersion, the package paraview). Two tries, each with a new Xvfb. If neither gives one,
    this machine cannot render OpenGL under Xvfb at all: the test says why and is skipped (exit 77),
    since that is the machine's limit, not our script's; pvbatch is not run."""
    probe = shutil.which("vtkProbeOpenGLVersion-pv5.11") or shutil.which("vtkProbeOpenGLVersion")
    why = []
    for attempt in (1, 2):
        with Xserver(tmp) as x:
            p = subprocess.run([probe], capture_output=True, text=True, timeout=120, env=x.env) if probe else None
            if p is None or p.returncode == 0:
                yield x
                return
            why.append("try %d on DISPLAY=%s: %s exited %d:\n%s\nXvfb said:\n%s" % (
                attempt, x.env["DISPLAY"], os.path.basename(probe), p.returncode, errors(p.stdout + p.stderr),
                x.log()))
    print("SKIP: no OpenGL window under Xvfb on this machine, so pvbatch cannot render here:\n" + "\n".join(why))
    sys.exit(77)


def near(img, rgb, tol=0.12):
    """pixels within tol of a colour on every channel (points rendered as spheres are shaded: a loose match)"""
    return int(np.count_nonzero(np.all(np.abs(img[:, :, :3] - np.array(rgb)) < tol, axis=2)))


def main():
    for tool in ("pvbatch", "Xvfb"):
        if shutil.which(tool) is None:
            print("SKIP: %s not installed (Debian packages paraview, xvfb, xauth; scripts/setup.sh --tools)" % tool)
            sys.exit(77)
    tmp = tempfile.mkdtemp(prefix="swarmsim-pvrender-")
    try:
        run([SWARMSIM, "run", os.path.join(SRC, "tests/data/scene.json"), "-o", "scene.h5", "--quiet"], tmp)
        run([SWARMSIM, "export", "scene.h5", "--format", "xdmf"], tmp)
        pv = ["pvbatch", SCRIPT, "scene.xmf2"]
        with opengl_display(tmp) as x:
            run(pv + ["-o", "frames/scene.%04d.png", "--frames", "10:12", "--size", "480", "320", "--point-size", "4"],
                tmp, env=x.env)
        names = sorted(os.listdir(os.path.join(tmp, "frames")))
        if names != ["scene.0010.png", "scene.0011.png"]:
            fail("expected scene.0010.png and scene.0011.png, got %s" % names)
        counts = []
        imgs = [matplotlib.image.imread(os.path.join(tmp, "frames", n)) for n in names]
        for n, img in zip(names, imgs):
            if img.shape[:2] != (320, 480):
                fail("%s is %dx%d, expected 480x320" % (n, img.shape[1], img.shape[0]))
            blue, orange = near(img, BLUE), near(img, ORANGE)
            grey = int(np.count_nonzero((np.ptp(img[:, :, :3], axis=2) < 0.03) & (img[:, :, 0] > 0.4) &
                                        (img[:, :, 0] < 0.85)))
            if blue < 50 or orange < 20 or grey < 2000:
                fail("%s: %d pixels of the first swarm's colour, %d of the second's, %d grey (obstacles); "
                     "expected at least 50, 20 and 2000" % (n, blue, orange, grey))
            counts.append((blue, orange, grey))
        if np.array_equal(imgs[0], imgs[1]):
            fail("frames 10 and 11 are the same image: nothing moved")
        with opengl_display(tmp) as x:
            run(pv + ["-o", "none.%04d.png", "--frames", "30:40"], tmp, expect=2, env=x.env)
            run(pv + ["-o", "one.png", "--frames", "3:5"], tmp, expect=2, env=x.env)
        print("ok: pvbatch rendered frames 10 and 11 with both swarms and the obstacles (pixels blue, orange, grey: %s)"
              % counts)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
