"""data_gen — synthetic environment maps with known smoothness or known shading integrals."""
