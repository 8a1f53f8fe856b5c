#!/usr/bin/env bash
# Gradescope's base image (Ubuntu 22.04) has Python 3.10; the course needs 3.11.
set -e
apt-get update
apt-get install -y python3.11 python3.11-venv
python3.11 -m venv /autograder/venv
/autograder/venv/bin/pip install "numpy>=2"
