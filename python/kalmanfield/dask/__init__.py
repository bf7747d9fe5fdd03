"""Scale-out on Dask: filter, denoise and segment dask arrays of frames chunk by chunk,
simulate fields and streams larger than memory, and spread the Monte Carlo experiments over
a ``dask.distributed`` cluster.

Installed with the ``dask`` extra (``pip install "kalmanfield[dask]"``: dask[array,dataframe]
and distributed); importing this module needs neither, calling its functions does. Every
function gives the same result whatever the chunking and the number of workers, equal to
the in-memory computation it names. The guide page :doc:`/guide/scale_out` says how it maps
onto a cluster.
"""

from .experiments import run_experiment
from .frames import denoise, filter, segment
from .sample import sample

__all__ = ["denoise", "filter", "run_experiment", "sample", "segment"]
