"""Blind instances of a study (`femu study --blind`, the default on suite problems).

A suite id is public and its instance deterministic: a plugin that learns the id (or probes
instances with the same bounds) could rebuild the problem and submit its truth. A blind
instance has the same family, size, bounds and start, but its truth and noise are drawn from
a key that only the evaluating side knows (`fe_problem.suite_problem(id, blind=key)`):

- the store's secret (STORE/.blind, 32 random bytes, mode 0600, made once with the store's
  first blind study: `Store.blind_secret`), which no worker can read (the store is hidden from
  them, adapters.confine);
- per instance the key HMAC-SHA256(secret, id) (`instance_key`), sent with its runs' tasks to
  the evaluating side (a study's run process, a Dask worker), never to an optimizer's worker,
  which gets only the bounds, the dimension and the evaluation channel.

The same store (secret) and seed give the same runs; another store gives other truths. The
paper problem is published data: it has no blind instance and stays public (its records say
``blind`` false). A noise-free blind instance keeps f_opt = 0 exactly; a noisy one is certified
here, on the evaluating side, when its study first runs it (`certificates`: the reference solve
of `fe_problem.suite.blind_certificate`: 1.8-3.0 s of CPU per instance at 12 parameters,
3-4 s at 24, 16 s at 48, measured on a loaded 2-core machine),
kept in STORE/.blind_fopt.json and carried by every record of the instance.
"""

from __future__ import annotations

import hashlib
import hmac
import json

from fe_problem.suite import FAMILIES, blind_certificate, suite_entry

from .store import Store, atomic_write_json
from .tasks import is_suite_id

#: The blind instances' certified f_opt (`certificates`): {id: [f_opt, precision, tag]}, tag a
#: digest of the instance key it was certified for (a remade secret certifies again).
CERTIFICATES_FILE = ".blind_fopt.json"


def instance_key(secret: bytes, problem_id: str) -> str:
    """The key of the blind instance of `problem_id` under the store's `secret` (hex HMAC-SHA256)."""
    return hmac.new(secret, f"femu-blind-instance:{problem_id}".encode(), hashlib.sha256).hexdigest()


def can_be_blind(variant: str) -> bool:
    """Whether a study's variant has a blind instance: a suite id other than the paper's."""
    return is_suite_id(variant) and FAMILIES[suite_entry(variant).family].structure != "paper"


def blind_keys(store: Store, variants: list[str]) -> dict[str, str]:
    """{variant: instance key} of the variants that have a blind instance; the store's secret
    is made on first use."""
    wanted = [v for v in variants if can_be_blind(v)]
    if not wanted:
        return {}
    secret = store.blind_secret(make=True)
    return {v: instance_key(secret, v) for v in wanted}


def certificates(store: Store, keys: dict[str, str]) -> dict[str, list[float]]:
    """{variant: [f_opt, precision]} of the noisy blind instances among `keys`: read from
    STORE/.blind_fopt.json, else certified now (`fe_problem.suite.blind_certificate`) and kept
    there, so that every run of an instance, resumed or not, carries the same f_opt."""
    noisy = [v for v in keys if FAMILIES[suite_entry(v).family].noisy]
    if not noisy:
        return {}
    path = store.path / CERTIFICATES_FILE
    try:
        known = json.loads(path.read_text())
    except FileNotFoundError:
        known = {}
    except ValueError:
        raise ValueError(f"{path}: not JSON; remove it to certify the blind instances again") from None
    out, changed = {}, False
    for v in noisy:
        entry, tag = known.get(v), hashlib.sha256(keys[v].encode()).hexdigest()[:16]
        if not (isinstance(entry, list) and len(entry) == 3 and all(isinstance(x, float) for x in entry[:2])
                and entry[2] == tag):
            entry = [*blind_certificate(v, keys[v]), tag]
            known[v], changed = entry, True
        out[v] = entry[:2]
    if changed:
        atomic_write_json(path, known)
    return out
