"""Write the synthetic "measured" records and the configuration of this directory.

The records are computed by an independent integration (``solve_ivp`` of the modal
equations of the simply supported beam under the HSLM-A1 axles,
``vsi_numba.verification.reference.moving_forces_ivp``) with the truth EI = 2.2e10 N m2
and a damping ratio of 2 %, plus white noise of 0.3 m s-2 (seeded)::

    python configs/calibration_synthetic/make_records.py
    vsi calibrate configs/calibration_synthetic/calibration.toml -o posterior.nc
    vsi report posterior.nc
"""

from pathlib import Path

from vsi_numba.verification.existing import write_case

if __name__ == "__main__":
    # the chains of V21 (vsi verify): 16 walkers x 500 kept steps after 40 of burn-in,
    # R-hat <= 1.05 on these records
    print(write_case(Path(__file__).parent, n_samples=8000, extra="burn_in = 40\n"))
