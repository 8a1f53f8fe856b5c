"""Hostile: writes its own 'answers' on the pipe the checker reads them from, then ends Python."""

import os
import sys

os.write(int(sys.argv[1]), b'{"task": 0, "result": {"outputs": "all right"}}\n{"done": tru')
os._exit(0)
