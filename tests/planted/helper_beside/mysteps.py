def weights():
    return 1 / 6, 1 / 3, 1 / 3, 1 / 6
