# Run by pvpython (tests/tools/paraview_test.py): open files with ParaView's own readers, as a user would,
# and dump what ParaView read to an .npz file for the test to compare with the .h5.
#   pvpython paraview_read.py xmf FILE.xmf OUT.npz FRAME [FRAME ...]
#   pvpython paraview_read.py ply OUT.npz FILE.ply [FILE.ply ...]
import os
import sys

import numpy as np
from paraview import servermanager as sm
from paraview.simple import OpenDataFile
from vtk.util.numpy_support import vtk_to_numpy


def points(block):
    return vtk_to_numpy(block.GetPoints().GetData()).astype(np.float64)


def blocks(data):
    """the leaves of a multiblock data set, in order"""
    out = []
    it = data.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        out.append(it.GetCurrentDataObject())
        it.GoToNextItem()
    return out


mode = sys.argv[1]
result = {}
if mode == "xmf":
    path, out, frames = sys.argv[2], sys.argv[3], [int(f) for f in sys.argv[4:]]
    # the readers for the file's name, the list the GUI's File > Open asks the user to choose from when it
    # has more than one (pqLoadDataReaction)
    factory = sm.vtkSMProxyManager.GetProxyManager().GetReaderFactory()
    factory.UpdateAvailableReaders()
    listed = factory.GetReaders(os.path.abspath(path), sm.ActiveConnection.Session)
    result["listed"] = np.array([listed.GetString(i) for i in range(1, listed.GetNumberOfStrings(), 3)])
    reader = OpenDataFile(path)  # ParaView picks the reader
    result["reader"] = np.array(reader.GetXMLName())
    times = list(reader.TimestepValues)
    result["times"] = np.array(times)
    for f in frames:
        reader.UpdatePipeline(times[f])
        data = sm.Fetch(reader)
        for k, b in enumerate(blocks(data)):
            pre = "f%d_b%d_" % (f, k)
            result[pre + "points"] = points(b)
            result[pre + "cells"] = np.array(b.GetNumberOfCells())
            pd = b.GetPointData()
            for name in ("velocity", "id", "swarm"):
                a = pd.GetArray(name)
                if a is not None:
                    result[pre + name] = np.array(vtk_to_numpy(a))  # a copy: the next update frees it
else:
    out, files = sys.argv[2], sys.argv[3:]
    for k, path in enumerate(files):
        reader = OpenDataFile(path)
        result["ply%d_reader" % k] = np.array(reader.GetXMLName())
        reader.UpdatePipeline()
        b = sm.Fetch(reader)
        result["ply%d_points" % k] = points(b)
        result["ply%d_cells" % k] = np.array(b.GetNumberOfCells())
        pd = b.GetPointData()
        result["ply%d_arrays" % k] = np.array([pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())])
np.savez(out, **result)
