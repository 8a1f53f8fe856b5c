"""Where you are in the exercises, and the course's other commands (curriculum/common/course.py; --grade is the
teacher's, curriculum/grading, docs/TEACHING.md):

    python -m exercises                      # every exercise, its status, and the next command to run
    python -m exercises --reset N            # start exercise N over
    python -m exercises --handin             # outputs/handin.zip, to hand in
    python -m exercises --grade PATH         # for teachers: gradebook.csv, grades.csv, summary.txt
"""

import sys

from curriculum.common.exercise import start

start(__file__)  # first: Ctrl-C is one line from here on

from curriculum.common import course

if __name__ == "__main__":
    sys.exit(course.main())
