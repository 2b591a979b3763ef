"""Observer LMIs, Jacobian bounds, infeasibility certificates and switched gains (paper 004)."""
