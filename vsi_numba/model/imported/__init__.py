"""Bring your own bridge: deck modes or FE matrices exported from another program.

Modules: :mod:`.common` (errors, tolerances, shared checks), :mod:`.table` (modes
tables), :mod:`.matrices` (FE matrices reduced to modes).

Both ways in end in a :class:`~vsi_numba.model.bridge.ModalBridge` of kind ``HERMITE``
along the track line the train runs on: x in metres from the left end of that line (the
first support it crosses), vertical deflection positive down, modes normalised to unit
modal mass (``phi^T M phi = 1``, so ``phi`` is in 1/sqrt(kg)).  Between stations the
mode shapes are a C2 cubic spline through the station values (not-a-knot ends), or the
Hermite cubic of the given values and slopes; the kernels evaluate exactly that cubic.

The sign of a whole mode is arbitrary (it cancels in every response), so "z up" exports
can be read as they are; each mode is flipped so that its largest value along the track
line is positive.  Only the *relative* sign of rotations and displacements matters
(``rotation_sign`` below).

1. Modes table (``bridge.kind = "modes_file"``, :func:`read_modes_table`)
--------------------------------------------------------------------------
Per retained mode: the natural frequency (Hz), the modal mass (kg) of the shape as
tabulated -- or a flag saying the shapes are already mass-normalised -- and the vertical
mode shape at stations along one or more track lines; optionally a damping ratio per
mode and slopes d(phi)/dx at the stations.  Shapes are divided by sqrt(modal mass).

*netCDF* (``.nc``; read with xarray; dimension order free)::

    dimensions:  mode, station, line (optional), support (optional)
    frequency(mode)             Hz     natural frequency, > 0
    modal_mass(mode)            kg     phi^T M phi of the shape as stored  [or the global
                                       attribute mass_normalised = 1]
    damping_ratio(mode)         1      optional (bridge.damping_ratio wins when given)
    x(station) or x(line, station)           m   station abscissa along the line, from
                                                 0 (NaN-padded when lines differ in length)
    shape(station, mode) or shape(line, station, mode)   vertical mode shape (any
                                                 consistent scale; m per unit coordinate)
    slope(...)                  1/m    optional, same dims as shape: d(shape)/dx
    line(line)                  str    track-line names (bridge.track_line picks one)
    support_x(support) or support_x(line, support)   m   optional support abscissae
                                                 along each line (NaN-padded): for plots,
                                                 default output points and reports
    section_x, section_moment, section_shear, load_x, influence_moment,
    influence_shear                     optional section forces of the modes and their
                                        static influence lines (:mod:`.effects`): the
                                        bending moment and shear force of the deck

*CSV* (``.csv``; one row per station and mode, "long" layout as FE post-processors
export it; ``#`` starts a comment; header names are case-insensitive)::

    mode,frequency,modal_mass,damping_ratio,line,x,shape,slope
    1,3.52,1.15e5,0.01,up,0.0,0.0,0.0123
    1,3.52,1.15e5,0.01,up,0.5,0.0061,0.0122
    ...

``mode`` (label), ``frequency`` (Hz), ``x`` (m) and ``shape`` are required;
``modal_mass`` (kg; else the config key ``bridge.mass_normalised = true``),
``damping_ratio``, ``line`` and ``slope`` (1/m) are optional.  Per-mode columns must
repeat the same value on every row of a mode; every mode must have a value at every
station of a line (same x set per line).

Checks (each a :class:`ModelFileError` naming the file and the problem): readable file,
required variables/columns, finite numbers (no NaN), frequencies > 0 and distinct,
modal masses > 0, stations strictly increasing from x = 0, a complete table (every mode
at every station), a table covering the whole bridge (last station at the sum of
``bridge.spans`` when given) and shapes that vanish at both ends of the line (the train
runs onto rigid track there: a non-zero end value would be a step in the rail).  Modes
are sorted by frequency.

2. Matrices (``bridge.kind = "matrices"``, :func:`read_matrices`)
------------------------------------------------------------------
Stiffness ``K`` and mass ``M`` of the structure in Matrix Market format
(``scipy.io.mmread``; coordinate or array, general or symmetric), same square size, SI
units (N/m, N, N m and kg, kg m^2 for rotational DOFs).  A station map (CSV) ties the
track line to the matrix DOFs::

    x,dof,rotation_dof,line
    0.0,0,1,up
    0.5,2,3,up

``x`` (m, strictly increasing from 0 along a line), ``dof`` (the vertical translation
DOF of the track node) are required; ``rotation_dof`` (the rotation about the
transverse axis, d(w)/dx times ``rotation_sign``) and ``line`` optional.  DOF numbers
are 0-based (``dof_base = 1`` for 1-based numbering, e.g. from a Fortran code); the
same base applies to ``fixed_dofs`` and ``vertical_dofs``.

Boundary conditions: ``fixed_dofs`` lists the DOFs held at zero (supports); omit it
when the exported matrices already have them removed/applied.  Modes: the lowest
``n_modes`` (or all up to ``max_frequency``) of ``K phi = w^2 M phi`` by
``scipy.sparse.linalg.eigsh`` in shift-invert mode around ``sigma = -1 rad^2/s^2``
(slightly below 0, so that an unsupported structure shows its rigid-body modes instead
of failing to factorise).  Checked: symmetry of K and M (relative 1e-8), finite entries,
no negative diagonal mass, K positive semi-definite, no rigid-body mode, and the
mass-normalisation ``|Phi^T M Phi - I| < 1e-6`` of the result.  Slopes along the track
come from the rotation DOFs when the map gives them (then the interpolation is the
exact Hermite FE field of a beam model), else from the spline.

Effective (participating) vertical mass of mode j: ``Gamma_j^2`` with
``Gamma_j = phi_j^T M r``, ``r`` = 1 on the vertical DOFs (``vertical_dofs``; default:
the station DOFs of every track line) and 0 elsewhere, divided by the total vertical
mass ``r^T M r`` (support DOFs included: for a consistent-mass beam these are exactly
``int m phi dx`` and ``int m dx``, so a simply supported span gives 8/pi^2 = 81.1% for
mode 1; the mass sitting on the supports never participates, so the sum over all modes
stays a little below 100%).  Stored per mode in
``ModalBridge.effective_mass_fraction`` and printed by ``vsi modes``.  For a 3-D model
give ``vertical_dofs`` (a list, or ``{start = 2, step = 6}`` for every 6th DOF from 2)
so that r is the whole vertical translation.

Notes
-----
Interpolation error of the spline between stations: O(h^4) for smooth modes (checked in
``tests/test_imported.py`` against a refined table); at 10 stations per half wavelength
the shape error is about 1e-4 of the amplitude.
"""

from vsi_numba.model.imported.common import ImportResult, ModelFileError
from vsi_numba.model.imported.matrices import modes_from_matrices, read_matrices
from vsi_numba.model.imported.table import read_modes_table

__all__ = [
    "ImportResult",
    "ModelFileError",
    "modes_from_matrices",
    "read_matrices",
    "read_modes_table",
]
