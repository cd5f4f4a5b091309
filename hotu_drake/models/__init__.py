"""`python -m hotu_drake.models`: list the embodiments, export and regenerate model files."""
