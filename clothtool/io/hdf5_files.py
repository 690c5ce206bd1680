"""Create HDF5 files whose failed writes raise where they happen.

HDF5 buffers raw data by default (a chunk cache per dataset, a sieve buffer for contiguous
datasets) and writes it out when the dataset's handle is freed. A write that fails then (a
full disk) happens inside h5py's object destructor, which can only print the error: the bake
went on, a flood of tracebacks followed and the corrupt file was kept. Without those buffers
each dataset write goes to the file in the call that makes it and raises OSError there;
metadata is written by ``flush``/``close``, which raise too.
"""

from __future__ import annotations

import os

# Fixed library version bounds: the same data gives the same bytes whichever HDF5 writes it.
HDF5_LIBVER = ("earliest", "v110")


def create_hdf5(path: str | os.PathLike):
    """A new (truncated) h5py.File at ``path`` opened for writing without raw-data buffers."""
    import h5py
    from h5py import h5f, h5p

    fapl = h5p.create(h5p.FILE_ACCESS)
    fapl.set_libver_bounds(h5f.LIBVER_EARLIEST, h5f.LIBVER_V110)
    fapl.set_fclose_degree(h5f.CLOSE_STRONG)  # closing the file closes every handle in it
    fapl.set_sieve_buf_size(0)
    metadata_slots, chunk_slots, _, preemption = fapl.get_cache()
    fapl.set_cache(metadata_slots, chunk_slots, 0, preemption)  # chunk cache of 0 bytes
    return h5py.File(h5f.create(os.fsencode(path), h5f.ACC_TRUNC, fapl=fapl))
