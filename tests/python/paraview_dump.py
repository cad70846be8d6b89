# SPDX-License-Identifier: BSD-2-Clause
"""Load XDMF files with one of ParaView's readers and dump what it loaded.

Run by test_xdmf.py under ParaView's own Python (pvpython, or Debian's
python3 with python3-paraview), not by pytest:

    pvpython paraview_dump.py READER OUT.json [--calculator NAME=EXPR] FILE.xdmf [FILE.xdmf ...]
    pvpython paraview_dump.py READER OUT.json --together FILE.xdmf FILE.xdmf ...

READER is a paraview.simple reader: XDMFReader (the legacy Xdmf2 reader,
"XDMF Reader" in the GUI), Xdmf3ReaderS or Xdmf3ReaderT. For each file,
OUT.json gets the time steps the reader reports and, at each of them, the
number of points, the structured dimensions, the points and every point
array, as lists of float64. With --calculator, a Calculator filter
(ResultArrayName NAME, Function EXPR) follows the reader and its output is
dumped instead: the reader's arrays and NAME. A composite dataset (the
obstacles' sidecar: one block an obstacle) also gets "blocks": each leaf
block's name, points, cells (the point ids of each) and cell arrays, in
the reader's order. With --together, the files are opened each with
READER in one session and joined by a Group Datasets filter, as a user
opens the cloth and its obstacles together; OUT.json gets, under the key
"together", the times of the group and the leaf blocks at each.
"""
import json
import sys

from paraview import servermanager, simple
from vtkmodules.util.numpy_support import vtk_to_numpy


def load(reader, path, calculator=None):
    src = open_reader(reader, path)
    times = src.TimestepValues
    reader_src = src
    if calculator:
        name, expr = calculator.split("=", 1)
        src = simple.Calculator(Input=reader_src, ResultArrayName=name, Function=expr,
                                ResultArrayType="Double")
    times = [] if times is None else ([float(times)] if isinstance(times, float) else [float(t) for t in times])
    steps = []
    for t in times or [None]:
        if t is None:
            src.UpdatePipeline()
        else:
            src.UpdatePipeline(t)
        data = servermanager.Fetch(src)
        step = {"class": data.GetClassName(), "n_points": int(data.GetNumberOfPoints()),
                "dims": None, "points": [], "arrays": {}}
        if hasattr(data, "GetDimensions"):
            dims = [0, 0, 0]
            data.GetDimensions(dims)
            step["dims"] = dims
        if data.IsA("vtkCompositeDataSet"):
            step["blocks"] = blocks(data)
        else:
            if data.GetNumberOfPoints() and data.GetPoints() is not None:
                step["points"] = vtk_to_numpy(data.GetPoints().GetData()).tolist()
            pd = data.GetPointData()
            for i in range(pd.GetNumberOfArrays()):
                a = pd.GetArray(i)
                step["arrays"][a.GetName()] = vtk_to_numpy(a).tolist()
        steps.append(step)
    if src is not reader_src:
        simple.Delete(src)
    simple.Delete(reader_src)
    return {"times": times, "steps": steps}


def blocks(data):
    """The leaf blocks of a composite dataset, in the reader's order."""
    found = []
    it = data.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        block = it.GetCurrentDataObject()
        meta = it.GetCurrentMetaData()
        name = meta.Get(data.NAME()) if meta is not None and meta.Has(data.NAME()) else None
        cells = []
        for c in range(block.GetNumberOfCells()):
            ids = block.GetCell(c).GetPointIds()
            cells.append([int(ids.GetId(j)) for j in range(ids.GetNumberOfIds())])
        cd = block.GetCellData()
        found.append({"name": name, "class": block.GetClassName(), "n_points": int(block.GetNumberOfPoints()),
                      "points": vtk_to_numpy(block.GetPoints().GetData()).tolist() if block.GetPoints() else [],
                      "cells": cells,
                      "cell_arrays": {cd.GetArray(i).GetName(): vtk_to_numpy(cd.GetArray(i)).tolist()
                                      for i in range(cd.GetNumberOfArrays())}})
        it.GoToNextItem()
    return found


def open_reader(reader, path):
    if reader == "XDMFReader":
        return simple.XDMFReader(FileNames=[path])
    return getattr(simple, reader)(FileName=[path])


def together(reader, paths):
    """The files opened together: each with reader, joined by Group Datasets,
    at the time keeper's steps (the union of the sources' times)."""
    srcs = [open_reader(reader, p) for p in paths]
    group = simple.GroupDatasets(Input=srcs)
    # the times the GUI's animation steps through: the union of the sources'
    times = simple.GetTimeKeeper().TimestepValues
    times = [] if times is None else ([float(times)] if isinstance(times, float) else [float(t) for t in times])
    steps = []
    for t in times:
        group.UpdatePipeline(t)
        data = servermanager.Fetch(group)
        steps.append({"class": data.GetClassName(), "blocks": [
            {k: b[k] for k in ("class", "n_points", "points")} for b in blocks(data)]})
    simple.Delete(group)
    for s in srcs:
        simple.Delete(s)
    return {"times": times, "steps": steps}


def main():
    reader, out, paths = sys.argv[1], sys.argv[2], sys.argv[3:]
    if paths and paths[0] == "--together":
        with open(out, "w") as f:
            json.dump({"together": together(reader, paths[1:])}, f)
        return
    calculator = None
    if paths and paths[0] == "--calculator":
        calculator, paths = paths[1], paths[2:]
    result = {path: load(reader, path, calculator) for path in paths}
    with open(out, "w") as f:
        json.dump(result, f)


if __name__ == "__main__":
    main()
