"""Identification: parameters, measurement models, FKM/IKM problems, solvers, identifiability."""
