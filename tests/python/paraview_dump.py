# SPDX-License-Identifier: BSD-2-Clause
"""Load XDMF files with one of ParaView's readers and dump what it loaded.

Run by test_xdmf.py under ParaView's own Python (pvpython, or Debian's
python3 with python3-paraview), not by pytest:

    pvpython paraview_dump.py READER OUT.json [--calculator NAME=EXPR] FILE.xdmf [FILE.xdmf ...]

READER is a paraview.simple reader: XDMFReader (the legacy Xdmf2 reader,
"XDMF Reader" in the GUI), Xdmf3ReaderS or Xdmf3ReaderT. For each file,
OUT.json gets the time steps the reader reports and, at each of them, the
number of points, the structured dimensions, the points and every point
array, as lists of float64. With --calculator, a Calculator filter
(ResultArrayName NAME, Function EXPR) follows the reader and its output is
dumped instead: the reader's arrays and NAME.
"""
import json
import sys

from paraview import servermanager, simple
from vtkmodules.util.numpy_support import vtk_to_numpy


def load(reader, path, calculator=None):
    if reader == "XDMFReader":
        src = simple.XDMFReader(FileNames=[path])
    else:
        src = getattr(simple, reader)(FileName=[path])
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


def main():
    reader, out, paths = sys.argv[1], sys.argv[2], sys.argv[3:]
    calculator = None
    if paths and paths[0] == "--calculator":
        calculator, paths = paths[1], paths[2:]
    result = {path: load(reader, path, calculator) for path in paths}
    with open(out, "w") as f:
        json.dump(result, f)


if __name__ == "__main__":
    main()
