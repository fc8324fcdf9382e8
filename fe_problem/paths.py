"""The names of the solver paths `AffineModel` takes (assembly.py), in a module of their own so
that the command line lists them without loading the solvers (issue 25)."""

#: `solver=` values: "auto" chooses by size (`assembly.solver_path`), the others force a path.
SOLVERS = ("auto", "dense", "sparse")
