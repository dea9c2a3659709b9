"""Reports for people: plots of measured against predicted, residuals, hysteresis loops."""
