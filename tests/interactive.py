"""Child processes that take Ctrl-C as a user's terminal gives it, however the suite was
started: a shell starts a background job (``cmd &``, ``nohup``) with SIGINT ignored, its
children inherit that, and Python then leaves SIGINT ignored instead of raising
KeyboardInterrupt. The stop-signal tests send SIGINT to such children."""

#: Python source that gives the process Python's own SIGINT handler back; put it before the
#: code of a ``python -c`` child that a test stops with SIGINT.
CTRL_C_RAISES = "import signal; signal.signal(signal.SIGINT, signal.default_int_handler)\n"
