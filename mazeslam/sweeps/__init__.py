"""Parameter grids over seeds: the runner (``runner``: local processes or a Dask cluster,
resumable), parallel calls for scripts (``pool``) and the tables and plots of a sweep
(``report``)."""
