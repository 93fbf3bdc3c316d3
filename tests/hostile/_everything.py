"""Every attack of the hostile zoo in one submission (copied as ``student/__init__.py`` next
to the zoo's files by the end-to-end tests): each graded integrator and ``camera_rays`` runs
a few attacks, once per student process, then returns black; an attack that works raises
(its message says ESCAPED, LEAK or WROTE). The pickle reply goes last: it ends the process's
conversation.
"""
from _hostile import black, registry
from escaped_daemon import radiance as daemon
from forbidden_calls import radiance as forbidden_calls
from handle_forgery import radiance as handle_forgery
from kernel_memory import radiance as kernel_memory
from libc_reference_read import radiance as libc_reads
from limit_parent import radiance as limit_parent
from parent_memory import radiance as parent_memory
from pickle_payload import radiance as pickle_reply
from reference_read import radiance as read_references
from signal_parent import radiance as kill_parent
from write_outside import radiance as write_results

DONE = set()


def chain(name, *attacks):
    """A radiance that runs ``attacks`` on its first call in this process, then black."""
    def radiance(self, scene, rays, rng):
        if name not in DONE:
            DONE.add(name)
            for attack in attacks:
                attack(self, scene, rays, rng)
        return black(rays)
    return radiance


ATTACKS = {"path": chain("path", read_references, libc_reads, parent_memory),
           "path_nee": chain("path_nee", daemon, limit_parent),
           "path_bsdf": chain("path_bsdf", kill_parent, kernel_memory),
           "direct": chain("direct", handle_forgery, forbidden_calls, pickle_reply)}
INTEGRATORS = {name: registry(radiance)[name] for name, radiance in ATTACKS.items()}


def camera_rays(camera, pixel, u_film):
    write_results(None, None, pixel, None)
    handle_forgery(None, None, pixel, None)
