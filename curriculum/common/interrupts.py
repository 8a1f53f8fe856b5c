"""The signal guard every chapter script and exercise installs on its first line.

    from curriculum.common.interrupts import guard
    guard("engine.py")  # from here on, Ctrl-C or SIGTERM ends in one line, exit 130 or 143

Until main() takes over (@one_line_failures installs its own handlers, which clean up the run's files),
nothing has been written, so a signal ends the process at once with one line. Loads nothing heavy.
"""

import os
import signal

EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}


def guard(prog: str) -> None:
    def stop(number, frame):
        what = "interrupted" if number == signal.SIGINT else "terminated"
        try:
            os.write(2, f"{prog}: {what} while starting: no file was written\n".encode())
        except OSError:
            pass
        os._exit(EXIT_CODES[number])

    for number in EXIT_CODES:
        if signal.getsignal(number) is not signal.SIG_IGN:  # nohup and friends ignore on purpose
            signal.signal(number, stop)
