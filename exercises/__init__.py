"""Chapter 3.3's exercises. Run each from the repo root, e.g. `python -m exercises.ex1_band`."""
