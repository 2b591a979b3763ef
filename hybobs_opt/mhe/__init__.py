"""Moving-horizon observers posed as MIQP / MILP in CasADi (paper 002, eq. 10)."""
