"""The incompressible (Navier–)Stokes models of a viscoplastic mass on Taylor–Hood P2/P1:
``state`` (fields and mesh-level plumbing shared by both), ``regularized`` (Picard on the
regularized law), ``augmented`` (augmented Lagrangian, exact rigid zones)."""
