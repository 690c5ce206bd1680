"""What every integrator shares: the integrator contract and registry (``integrators``)."""
