"""Start the student process's fork server before any reference image is loaded."""
from autograder.isolation import start_fork_server


def pytest_sessionstart(session):
    start_fork_server()
