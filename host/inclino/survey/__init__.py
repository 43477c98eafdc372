"""Survey: reference field, well path, error model, repeatability, QC reference, figures."""
