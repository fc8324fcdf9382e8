"""The size limits every input is checked against up front, in one place (docs/bad-input.md).

Each limit is checked before the work it bounds starts, so that a request too large is refused
in well under a second with the size and the limit, never after minutes or with a bare
MemoryError. Others live beside what they bound: `jsonutil.MAX_JSON_BYTES` (JSON files),
`assembly.MAX_DENSE_BYTES` (the dense path's matrices), `identification.frf_io.MAX_NPZ_BYTES`
and `MAX_TEXT_FRF_BYTES` (FRF files).
"""

#: The most free DOFs the sparse path takes: a model larger than this is refused up front
#: (its factorisations could exhaust memory, and each point would take minutes). A 90,000-DOF
#: beam solves in about 7 s and 360 MB on this project's 2-core machine. Generated and split
#: models are held to it before they are built.
MAX_SPARSE_DOFS = 250_000
