"""VTK XML files for ParaView: a VTU with FieldData and a comment, and a PVD time collection.

meshio 5 writes the mesh, its point and cell data (compressed binary), but drops
``field_data`` when it writes VTU.  ``write_vtu`` therefore writes the file with meshio and adds
a ``<FieldData>`` block (the dataset-wide values: ParaView lists them in the Information panel
and in the spreadsheet view's "Field Data" attribute, and a ``TimeValue`` there is a dataset's
time) and an XML comment (units, what the file is) before renaming the file into place.  The
FieldData arrays are numeric (Float64/Int64, ascii), so the file still reads back with
``meshio.read`` (which returns them as ``field_data``); a string array would not (meshio 5
refuses the VTK type String).

``write_pvd`` writes a ParaView Data collection: one dataset per time step, each a VTU file
named relative to the collection, so the collection and its folder can be moved together.
Every file is written atomically (``gimbal_reduction.workflow.provenance.atomic_path``).
"""
from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np

from gimbal_reduction.workflow.provenance import atomic_path


def _comment_text(text):
    """An XML comment's text: no "--" inside, padded by spaces."""
    return " " + " ".join(str(text).replace("--", "- -").split()) + " "


def _field_array(parent, name, values):
    values = np.atleast_1d(np.asarray(values))
    if values.ndim != 1:
        raise ValueError(f"field data {name!r}: a 1-D array is expected, got shape {values.shape}")
    integer = np.issubdtype(values.dtype, np.integer) or values.dtype == bool
    da = ET.SubElement(parent, "DataArray", type="Int64" if integer else "Float64", Name=str(name),
                       NumberOfTuples=str(values.size), format="ascii")
    # repr of a float64 reads back to the same number (the values are compared exactly in tests)
    da.text = " ".join(str(int(v)) if integer else repr(float(v)) for v in values)
    return da


def add_field_data(path, field_data, comment=None):
    """Add FieldData arrays ({name: 1-D numeric}) and a leading XML comment to the VTU at ``path``
    (rewritten in place: call it on a temporary file)."""
    tree = ET.parse(path)
    root = tree.getroot()
    grid = root.find("UnstructuredGrid")
    if grid is None:
        raise ValueError(f"{path}: not a VTU file (no UnstructuredGrid element)")
    if field_data:
        block = ET.Element("FieldData")
        for name, values in field_data.items():
            _field_array(block, name, values)
        block.text = block.tail = "\n"
        for da in block:
            da.tail = "\n"
        grid.insert(0, block)
    if comment:
        note = ET.Comment(_comment_text(comment))
        note.tail = "\n"
        root.insert(0, note)
    tree.write(path, xml_declaration=True, encoding="utf-8")


def write_vtu(path, mesh: meshio.Mesh, field_data=None, comment=None):
    """Write ``mesh`` (its point and cell data) as VTU with FieldData ``field_data`` (1-D numeric
    arrays) and an XML comment, atomically."""
    with atomic_path(path) as tmp:
        meshio.write(str(tmp), mesh, file_format="vtu")
        add_field_data(tmp, field_data or {}, comment)
    return str(path)


def read_field_data(path):
    """{name: array} of a VTU file's FieldData (read by meshio)."""
    return {k: np.asarray(v) for k, v in meshio.read(str(path), file_format="vtu").field_data.items()}


def write_pvd(path, datasets, comment=None):
    """A ParaView Data collection at ``path``: ``datasets`` [(time [s], file)], each file written
    relative to the collection's folder.  Atomic."""
    root = ET.Element("VTKFile", type="Collection", version="0.1",
                      byte_order="LittleEndian")
    if comment:
        root.append(ET.Comment(_comment_text(comment)))
    coll = ET.SubElement(root, "Collection")
    base = os.path.dirname(os.path.abspath(path))
    for time, file in datasets:
        rel = os.path.relpath(os.path.abspath(file), base)
        ET.SubElement(coll, "DataSet", timestep=repr(float(time)), group="", part="0",
                      file=Path(rel).as_posix())
    ET.indent(root)
    with atomic_path(path) as tmp:
        ET.ElementTree(root).write(tmp, xml_declaration=True, encoding="utf-8")
    return str(path)


def read_pvd(path):
    """[(time [s], absolute file path)] of a PVD collection, in the file's order."""
    root = ET.parse(path).getroot()
    coll = root.find("Collection")
    if root.get("type") != "Collection" or coll is None:
        raise ValueError(f"{path}: not a PVD collection")
    base = os.path.dirname(os.path.abspath(path))
    return [(float(d.get("timestep")), os.path.join(base, d.get("file"))) for d in coll.iter("DataSet")]
