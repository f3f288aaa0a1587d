"""HDF5 datasets, attributes and appended rows written through h5py's
low-level interface. They are the objects h5py's `group[name] = values`,
`obj.attrs[key] = value` and `dset.resize(...); dset[n0:n1] = rows` make
(a contiguous dataset of the array's type and shape; a scalar
variable-length UTF-8 string, or a number or array of numbers of its
type), without the high-level calls' checks and conversions, which cost
more than the writes themselves for the small arrays of a snapshot or a
checkpoint (docs/performance.md, "Snapshot and checkpoint writes")."""

import h5py
import numpy as np

#: intermediate groups of a dataset name with slashes ('nodes/x') are made
#: as the high-level interface makes them
_LINK_CREATE = h5py.h5p.create(h5py.h5p.LINK_CREATE)
_LINK_CREATE.set_create_intermediate_group(True)
_TEXT = h5py.string_dtype()
_TEXT_TYPE = h5py.h5t.py_create(_TEXT, logical=True)


def write_dataset(group, name, values):
    """Create the dataset `name` in the open `group` holding `values` (an
    array of numbers or booleans; anything else through the high-level
    interface) and return its identifier (h5py.h5d.DatasetID)."""
    data = np.asarray(values)
    if not data.flags.c_contiguous:
        data = np.ascontiguousarray(data)    # (which would make a 0-d array 1-d)
    if data.dtype.kind not in "biuf":
        group[name] = data
        return group[name].id
    space = h5py.h5s.create_simple(data.shape)
    dset = h5py.h5d.create(group.id, name.encode(), h5py.h5t.py_create(data.dtype, logical=True), space,
                           lcpl=_LINK_CREATE)
    if data.size:
        dset.write(h5py.h5s.ALL, h5py.h5s.ALL, data)
    return dset


def append_rows(group, name, n0, values):
    """Write the one-dimensional `values` at rows n0.. (None: after the
    last row) of the extendable dataset `name` of the open `group`,
    extending it to n0 + len(values) rows (as `dset.resize((n1,));
    dset[n0:n1] = values`)."""
    data = np.ascontiguousarray(values, dtype=np.float64)
    dset = h5py.h5d.open(group.id, name.encode())
    if n0 is None:
        n0 = dset.shape[0]
    dset.set_extent((n0 + len(data),))
    rows = dset.get_space()
    rows.select_hyperslab((n0,), (len(data),))
    dset.write(h5py.h5s.create_simple((len(data),)), rows, data)


def write_attribute(obj, key, value):
    """Create the attribute `key` of the open dataset or group `obj` (or
    its identifier) holding `value`: a string (a scalar variable-length
    UTF-8 string), a number or an array of numbers; anything else through
    the high-level interface."""
    oid = obj.id if isinstance(obj, (h5py.Group, h5py.Dataset)) else obj
    if isinstance(value, str):
        tid, data = _TEXT_TYPE, np.array(value, dtype=_TEXT)
    else:
        data = np.asarray(value)
        if data.dtype.kind not in "biuf":
            h5py.AttributeManager(_high_level(oid))[key] = value
            return
        tid = h5py.h5t.py_create(data.dtype, logical=True)
    space = h5py.h5s.create(h5py.h5s.SCALAR) if data.ndim == 0 else h5py.h5s.create_simple(data.shape)
    h5py.h5a.create(oid, key.encode(), tid, space).write(np.ascontiguousarray(data))


def _high_level(oid):
    """The h5py object of an identifier (a dataset or a group)."""
    return h5py.Dataset(oid) if isinstance(oid, h5py.h5d.DatasetID) else h5py.Group(oid)
