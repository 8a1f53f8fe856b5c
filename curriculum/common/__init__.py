"""What every chapter script shares (a script's first line imports the guard: importing the package loads nothing)."""
