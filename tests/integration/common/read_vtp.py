"""Reads a .vtp frame with VTK's own XML reader and prints what it holds.

Usage: python3 read_vtp.py FRAME.vtp
Prints one JSON object: points, polys, and for each point-data array its
number of components and tuples.
"""
import json
import sys

import vtk

reader = vtk.vtkXMLPolyDataReader()
reader.SetFileName(sys.argv[1])
reader.Update()
data = reader.GetOutput()
arrays = {}
pd = data.GetPointData()
for i in range(pd.GetNumberOfArrays()):
    a = pd.GetArray(i)
    arrays[pd.GetArrayName(i)] = {
        "components": a.GetNumberOfComponents(),
        "tuples": a.GetNumberOfTuples(),
        "first": list(a.GetTuple(0)),
    }
print(json.dumps({
    "points": data.GetNumberOfPoints(),
    "polys": data.GetNumberOfPolys(),
    "first_point": list(data.GetPoint(0)),
    "arrays": arrays,
}))
