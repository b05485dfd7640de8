#!/usr/bin/python3
"""scripts/preview.py --video renders a run to MP4 that ffprobe and ffmpeg read back (docs/tools.md#video).

A two-swarm run with obstacles (tests/data/scene.json, 24 frames) is rendered to MP4; ffprobe must count
one video frame per HDF5 frame, at the run's frame rate and the requested even pixel size; a --frames
range gives exactly that many frames; ffmpeg decodes the frames and they change over time (the insects
move) while the obstacles' grey pixels are there in every frame. Targets that must never be replaced are
refused with exit code 3 and left as they were: a FIFO, a directory, a symlink to /dev/null, an existing
file without --force, the input file itself. A failed render leaves no temporary file behind.
Exit 77 (skipped) without ffmpeg/ffprobe.
"""
import glob
import json
import os
import shutil
import stat
import subprocess
import sys
import tempfile

import h5py
import numpy as np

SWARMSIM = os.environ.get("SWARMSIM", "swarmsim")
SRC = os.environ.get("SWARMSIM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
PREVIEW = os.path.join(SRC, "scripts", "preview.py")


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def run(cmd, expect=0, cwd=None):
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=240)
    if p.returncode != expect:
        fail("%s exited %d (expected %d):\n%s%s" % (" ".join(cmd), p.returncode, expect, p.stdout, p.stderr))
    return p


def probe(path):
    p = run(["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
             "stream=codec_name,width,height,r_frame_rate,nb_read_frames,pix_fmt", "-of", "json", path])
    streams = json.loads(p.stdout)["streams"]
    if len(streams) != 1:
        fail("%s: ffprobe finds %d video streams, expected 1" % (path, len(streams)))
    return streams[0]


def decode(path, w, h):
    """Every frame of the video as an (n, h, w, 3) uint8 array, decoded by ffmpeg."""
    p = subprocess.run(["ffmpeg", "-v", "error", "-i", path, "-f", "rawvideo", "-pix_fmt", "rgb24", "-"],
                       capture_output=True, timeout=240)
    if p.returncode != 0:
        fail("ffmpeg cannot decode %s: %s" % (path, p.stderr.decode(errors="replace")))
    data = np.frombuffer(p.stdout, dtype=np.uint8)
    if data.size % (w * h * 3):
        fail("%s: decoded %d bytes, not a whole number of %dx%d frames" % (path, data.size, w, h))
    return data.reshape(-1, h, w, 3)


def main():
    for tool in ("ffmpeg", "ffprobe"):
        if shutil.which(tool) is None:
            print("skipped: %s not found (Debian package ffmpeg; scripts/setup.sh --tools installs it)" % tool)
            return 77
    with tempfile.TemporaryDirectory(prefix="swarmsim_ffmpeg_") as tmp:
        h5path = os.path.join(tmp, "scene.h5")
        run([SWARMSIM, "run", os.path.join(SRC, "tests", "data", "scene.json"), "-o", h5path])
        with h5py.File(h5path, "r") as f:
            frames = f["time"].shape[0]
            fps = round(1.0 / float(f.attrs["frame_dt"]))
        if frames < 10:
            fail("the scene run has %d frames; the test needs at least 10" % frames)

        # the whole run: one video frame per HDF5 frame, the run's frame rate, even pixel sizes
        mp4 = os.path.join(tmp, "scene.mp4")
        run(["/usr/bin/python3", PREVIEW, h5path, "--video", mp4, "--size", "6.4", "4.8", "--trail", "3"])
        s = probe(mp4)
        if s["codec_name"] != "h264" or s["pix_fmt"] != "yuv420p":
            fail("codec %s / %s, expected h264 / yuv420p" % (s["codec_name"], s["pix_fmt"]))
        if int(s["nb_read_frames"]) != frames:
            fail("ffprobe counts %s frames, the .h5 has %d" % (s["nb_read_frames"], frames))
        if (int(s["width"]), int(s["height"])) != (640, 480):
            fail("video is %sx%s, expected 640x480" % (s["width"], s["height"]))
        num, den = (int(x) for x in s["r_frame_rate"].split("/"))
        if num != fps * den:
            fail("frame rate %s, expected %d (1 / frame_dt)" % (s["r_frame_rate"], fps))
        video = decode(mp4, 640, 480)
        if len(video) != frames:
            fail("ffmpeg decodes %d frames, expected %d" % (len(video), frames))
        # the insects move: consecutive frames differ; the obstacles (grey, the same in every frame) stay
        diffs = [int(np.count_nonzero(np.abs(video[i].astype(int) - video[i + 1]).sum(2) > 60))
                 for i in range(frames - 1)]
        if min(diffs) == 0:
            fail("frames %d and %d are identical: nothing moves" % (diffs.index(0), diffs.index(0) + 1))
        grey = lambda im: np.count_nonzero((np.abs(im[:, :, 0].astype(int) - im[:, :, 2]) < 12) &
                                           (im[:, :, 0] > 90) & (im[:, :, 0] < 190))
        bare = os.path.join(tmp, "bare.mp4")
        run(["/usr/bin/python3", PREVIEW, h5path, "--video", bare, "--size", "6.4", "4.8", "--no-obstacles",
             "--frames", "0:1"])
        without = decode(bare, 640, 480)[0]
        if grey(video[0]) < grey(without) + 500:
            fail("the obstacles are not drawn: %d grey pixels with them, %d without" % (grey(video[0]),
                                                                                          grey(without)))

        # --frames A:B: exactly those frames
        part = os.path.join(tmp, "part.mp4")
        run(["/usr/bin/python3", PREVIEW, h5path, "--video", part, "--frames", "5:12", "--fps", "10"])
        s = probe(part)
        if int(s["nb_read_frames"]) != 7 or s["r_frame_rate"] != "10/1":
            fail("--frames 5:12 --fps 10 gave %s frames at %s" % (s["nb_read_frames"], s["r_frame_rate"]))
        run(["/usr/bin/python3", PREVIEW, h5path, "--video", os.path.join(tmp, "none.mp4"), "--frames", "30:40"],
            expect=2)

        # targets that are never replaced, even with --force: exit 3, left as they were
        fifo = os.path.join(tmp, "fifo.mp4")
        os.mkfifo(fifo)
        folder = os.path.join(tmp, "folder.mp4")
        os.mkdir(folder)
        null_link = os.path.join(tmp, "null.mp4")
        os.symlink("/dev/null", null_link)
        for target, kind in ((fifo, stat.S_ISFIFO), (folder, stat.S_ISDIR)):
            p = run(["/usr/bin/python3", PREVIEW, h5path, "--video", target, "--force"], expect=3)
            if "not replaced" not in p.stderr:
                fail("refusing %s: the message does not say so: %s" % (target, p.stderr))
            if not kind(os.lstat(target).st_mode):
                fail("%s was replaced" % target)
        p = run(["/usr/bin/python3", PREVIEW, h5path, "--video", null_link, "--force"], expect=3)
        if not os.path.islink(null_link) or os.readlink(null_link) != "/dev/null":
            fail("the symlink to /dev/null was replaced")
        run(["/usr/bin/python3", PREVIEW, h5path, "--video", h5path, "--force"], expect=3)
        size = os.path.getsize(mp4)
        run(["/usr/bin/python3", PREVIEW, h5path, "--video", mp4], expect=3)  # exists, no --force
        if os.path.getsize(mp4) != size:
            fail("an existing video was changed without --force")
        leftovers = glob.glob(os.path.join(tmp, ".*part*"))
        if leftovers:
            fail("temporary files left behind: %s" % leftovers)
    print("ok: %d frames at %d fps, --frames, refusals; grey pixels %d with obstacles, %d without"
          % (frames, fps, grey(video[0]), grey(without)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
