"""The renderer error prediction: warped spectra, their tail, the predictor."""
