"""Stage 2 of a run, rendering: a run's templates filled with its values.

Takes an :class:`~slamq.runner.config.Algorithm` and a run's values (what
:func:`slamq.runner.planning.run_values` gives: ``{input}``, ``{out}``, ``{param.NAME}``,
``{slot}``...); gives the command line of each step (:func:`render_command`), the text of
the algorithm's config file from its template and overrides (:func:`render_config_file`)
and the environment the programs start with (:func:`run_env`). The placeholders
themselves are filled by :func:`slamq.runner.config.render`.

Rendering writes nothing: :mod:`slamq.runner.planning` hashes what it gives into the run
key, :mod:`slamq.runner.execution` writes it into the run folder and starts the programs.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

from slamq.errors import ParamError
from slamq.runner.config import Algorithm, render

__all__ = ["render_command", "render_config_file", "run_env"]


def render_command(cmd: list[str] | str, values: dict[str, Any], where: str) -> list[str] | str:
    """A step's command with its placeholders filled: a shell string stays a string, an
    argument list stays a list (``where`` names the setting in errors).

    Examples
    --------
    >>> render_command(["echo", "{input}"], {"input": "a b.bag"}, "command")
    ['echo', 'a b.bag']
    """
    if isinstance(cmd, str):
        return render(cmd, values, where)
    return [render(c, values, where) for c in cmd]


def render_config_file(algo: Algorithm, values: dict[str, Any]) -> str | None:
    """The text of the algorithm's config file for one run (template + overrides).

    Overrides are ``SECTION.key`` for ini files (the key's line in that section is replaced;
    a missing key is appended to its section) and dotted paths for YAML files.
    """
    if algo.config_template is None:
        return None
    where = f"algorithms.{algo.name}.config_template"
    try:
        text = algo.config_template.read_text()
    except OSError as exc:
        raise ParamError(f"{algo.config_template}: cannot read {where} "
                         f"({exc.strerror or exc})") from exc
    over = {k.lstrip("+"): render(str(v), values, f"algorithms.{algo.name}.config_overrides.{k}")
            for k, v in algo.config_overrides.items()}
    if algo.config_template.suffix.lower() in (".yaml", ".yml"):
        import yaml

        doc = yaml.safe_load(text) or {}
        for k, v in over.items():
            node = doc
            parts = k.split(".")
            for p in parts[:-1]:
                node = node.setdefault(p, {})
            node[parts[-1]] = yaml.safe_load(v) if v != "" else v
        return yaml.safe_dump(doc, sort_keys=False)
    return _ini_override(text, over, algo.config_template)


def _ini_override(text: str, over: dict[str, str], where: Path) -> str:
    pending: dict[str, dict[str, str]] = {}
    for k, v in over.items():
        if "." not in k:
            raise ParamError(f"{where}: ini override {k!r} must be SECTION.key")
        sec, key = k.rsplit(".", 1)
        pending.setdefault(sec, {})[key] = v
    lines = text.splitlines()
    out: list[str] = []
    section = None

    def flush(sec: str | None) -> None:
        for key, v in pending.pop(sec, {}).items() if sec is not None else []:
            out.append(f"{key}={v}")

    for line in lines:
        m = re.match(r"\s*\[(.+?)\]", line)
        if m:
            flush(section)
            section = m.group(1)
        else:
            km = re.match(r"\s*([A-Za-z0-9_.\-]+)\s*=", line)
            if km and section in pending and km.group(1) in pending[section]:
                line = f"{km.group(1)}={pending[section].pop(km.group(1))}"
        out.append(line)
    flush(section)
    for sec, keys in pending.items():
        out.append(f"[{sec}]")
        out.extend(f"{k}={v}" for k, v in keys.items())
    return "\n".join(out) + "\n"


def run_env(algo: Algorithm, values: dict[str, Any]) -> dict[str, str]:
    """The environment of a run's programs: this process's, the slot's ROS domain and
    master port, and the algorithm's ``env`` entries rendered."""
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(values["ros_domain_id"])
    env["ROS_MASTER_URI"] = f"http://localhost:{values['ros_master_port']}"
    for k, v in algo.env.items():
        env[k] = render(v, values, f"algorithms.{algo.name}.env.{k}")
    return env


