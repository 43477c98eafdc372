"""File formats: raw datasets, calibration files and images, safe output."""
