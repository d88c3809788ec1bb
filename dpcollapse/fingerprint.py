"""The run's identity: the config fingerprint stored in every checkpoint, and the check
that a checkpoint found in a run directory belongs to that run (``--resume``)."""

from __future__ import annotations

import logging
from pathlib import Path

from dpcollapse.config import Config, config_to_dict
from dpcollapse.errors import ConfigError

log = logging.getLogger("dpcollapse")


def config_fingerprint(cfg: Config) -> str:
    """Hash of the config without the keys a resume may change (``io.rundir.RESUMABLE_KEYS``)."""
    return _fingerprint(config_to_dict(cfg))


def _fingerprint(data: dict) -> str:
    """``config_fingerprint`` of a config as a plain dict (e.g. a run's config.yaml)."""
    import copy
    import hashlib
    import json

    from dpcollapse.io.rundir import RESUMABLE_KEYS

    data = copy.deepcopy(data)
    for key in RESUMABLE_KEYS:
        section, name = key.split(".")
        data.get(section, {}).pop(name, None)
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()[:16]


def _saved_fingerprint(run_dir: Path) -> str | None:
    """The fingerprint the run's program gave its config.yaml (as written, before this program
    read it: a program older than a key hashed a config without it); None if unreadable."""
    import yaml

    try:
        data = yaml.safe_load((run_dir / "config.yaml").read_text())
    except (OSError, yaml.YAMLError):
        return None
    return _fingerprint(data) if isinstance(data, dict) else None


def check_identity(stored: dict | None, mine: dict, run_dir: Path) -> str:
    """The run id to continue under: the checkpoint's, when it was written by this run
    (its config fingerprint is this config's, or — written by an older program, whose config
    lacked keys added since — the one of the run's config.yaml, which ``io.rundir`` has found
    equal to this config; and the run id run.json names). A checkpoint of another run (copied
    in) is ConfigError naming both; one older than fingerprints is trusted."""
    import json

    if not stored:
        log.warning("the checkpoint predates run fingerprints: it is trusted to be this run's")
        return mine["run_id"]
    try:
        owner = json.loads((run_dir / "run.json").read_text()).get("run_id")
    except (OSError, ValueError, AttributeError):
        owner = None
    ours = stored.get("fingerprint") in (mine["fingerprint"], _saved_fingerprint(run_dir))
    if not ours or (owner and stored.get("run_id") != owner):
        raise ConfigError(
            f"--resume: the checkpoint in {run_dir} belongs to another run (run "
            f"{stored.get('run_id')}, config fingerprint {stored.get('fingerprint')}) than this "
            f"one (run {owner or 'unknown'}, config fingerprint {mine['fingerprint']}): was it "
            "copied in? Start the run again with --overwrite")
    return stored.get("run_id") or mine["run_id"]
