"""Support code for the exercises: nothing here is yours to edit. Your file is exercises/ex2_integrators.py."""
