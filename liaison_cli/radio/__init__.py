"""Link budget and ranging error models (Turan et al. 2022, Section 2)."""
