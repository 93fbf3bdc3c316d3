"""A stand-in for OpenEXR's reader in the interrupt tests (tests/test_interrupts.py,
tests/test_external_images.py)."""
import signal


def swallowing_reader(interrupt: bool):
    """A reader that, like OpenEXR's, turns an interrupt during the read into its own error."""
    def read(*args, **kwargs):
        try:
            if interrupt:
                signal.raise_signal(signal.SIGINT)
        except KeyboardInterrupt:
            pass
        raise RuntimeError("initialization failed")
    return read


class InterruptSecondTest:
    """A pytest plugin (``-p tests.interrupting``) for the grader's interrupt test: SIGINT
    arrives as the second selected test starts, deterministically."""

    calls = 0

    def pytest_runtest_call(self, item):
        InterruptSecondTest.calls += 1
        if InterruptSecondTest.calls == 2:
            signal.raise_signal(signal.SIGINT)


def pytest_configure(config):
    """Registers :class:`InterruptSecondTest` when this module is loaded with ``-p``."""
    config.pluginmanager.register(InterruptSecondTest(), "interrupt-second-test")
