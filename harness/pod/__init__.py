"""POD (section 2.3): snapshot selection and bases from full SPH runs."""
