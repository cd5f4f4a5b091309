"""`python -m hotu_drake.bench ...`: benchmarks that print JSON."""
