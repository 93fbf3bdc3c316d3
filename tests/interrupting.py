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
