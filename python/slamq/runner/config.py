"""The runner's configuration: a YAML file or the same structure as a Python dict.

::

    output: runs                   # folder (relative to the config file)
    iterations: 3
    parallel: 2                    # runs at once (1 for playback-driven ROS runs)
    timeout: 600                   # hard cap per run, seconds
    startup_timeout: 60            # ROS recipes: readiness wait per step
    retries: 1                     # infrastructure failures only (start failed, not ready)
    grace: [5, 5]                  # seconds after SIGINT, after SIGTERM
    min_poses: 2                   # fewer poses = degenerate
    report: true                   # build the HTML report after scoring
    evaluate: {ate_align: se2}     # keywords of slamq.evaluate_many
    sequences:
      loop: {input: data/loop.rawlog, groundtruth: gt.txt}
      gen: {synth: {worlds: 20, noise: [low, high], seeds: [0, 1, 2]}}   # generated
      csail: {carmen: data/csail.clf, relations: data/csail.relations}   # converted
    algorithms:
      rbpf:
        command: [rbpf-slam, "{config}", "{input}"]   # list: no shell; a string: sh -c
        config_template: /usr/share/mrpt/config_files/rbpf-slam/gridmapping_optimal_sampling.ini
        config_overrides: {MappingApplication.logOutput_dir: "{out}",
                           MappingApplication.sampleSize: "{param.particles}"}
        params: {particles: [5, 20]}               # a list = a sweep axis
        outputs:
          map: {path: "finalMap_*.png", format: mrpt}           # mrpt | yaml | image
          trajectory: {path: log_estimated_path.txt, format: mrpt}   # mrpt | tum | ...
          # icp-slam / graphslam-engine log poses by index: times: "{input}.steps.txt"
          snapshots: {path: "maps/mapbuilt_*.png", format: mrpt}

Placeholders in commands, overrides and environment values: ``{sequence} {input} {out}
{iteration} {seed} {config} {slot} {ros_domain_id} {ros_master_port} {param.NAME}``;
other braces are left alone. ``{out}`` is ``<run folder>/out``, the command's working
folder. A ``synth:`` sequence is a recipe for generated sequences with exact ground truth
(:mod:`slamq.synth.benchmark`); a ``carmen:`` or ``bag:`` sequence is a real robot's log,
written as an MRPT rawlog with its own timestamps before the runs
(:mod:`slamq.runner.recorded`).

A sequence's ground truth: ``groundtruth`` (a trajectory: ``ate_*`` columns),
``groundtruth_map`` (``gt_*``) and ``relations`` (the relations of Kümmerle et al. 2009:
``rel_*``, docs/spec.md 6a). ``unsorted: error | sort | last`` says what reading a run's
trajectory does when its timestamps go backwards (as the Intel log's do): refuse it (the
run ends ``no_output``), sort the poses by time, or keep those after the last jump back.
A ROS algorithm gives ``recipe:`` (a list of steps)
instead of ``command:``; see :mod:`slamq.runner.runner`.
"""

from __future__ import annotations

import itertools
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from slamq.errors import ParamError
from slamq.params import SETTINGS
from slamq.runner.recorded import KINDS as RECORDED_KINDS
from slamq.runner.recorded import Recorded, parse_recorded
from slamq.synth.benchmark import Generated, expand

__all__ = ["RunConfig", "Algorithm", "SequenceSpec", "Output", "Step", "load_config", "render"]

_PLACEHOLDER = re.compile(r"\{([A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z0-9_\-]+)?)\}")
MAP_FORMATS = ("mrpt", "yaml", "image", "bag", "pbstream")
TRAJECTORY_FORMATS = ("mrpt", "tum", "kitti", "euroc", "csv", "auto", "bag", "pbstream")


def render(template: str, values: dict[str, Any], where: str = "template") -> str:
    """Fill ``{name}`` / ``{param.NAME}`` placeholders; unknown plain names stay as written.

    Examples
    --------
    >>> render("run {input} -n {param.n} ${HOME}", {"input": "a b", "param.n": 5})
    'run a b -n 5 ${HOME}'
    """

    def sub(m: re.Match) -> str:
        name = m.group(1)
        if name in values:
            return str(values[name])
        if name.startswith("param."):
            known = ", ".join(sorted(k for k in values if "." in k)) or "none"
            raise ParamError(f"{where}: unknown parameter {{{name}}} (known: {known})")
        return m.group(0)

    return _PLACEHOLDER.sub(sub, template)


@dataclass(frozen=True)
class Output:
    """Where a run's map / trajectory / snapshots appear (a glob under ``{out}``)."""

    path: str
    format: str
    topic: str | None = None
    #: A trajectory output timed by step or node index (``icp-slam``'s pose log,
    #: ``graphslam-engine``'s graph): a file listing one clock time per index (placeholders
    #: such as ``{input}`` filled in), e.g. ``"{input}.steps.txt"`` beside a rawlog
    #: written by :mod:`slamq.synth.writers`.
    times: str | None = None


@dataclass(frozen=True)
class Step:
    """One process of a ROS recipe.

    ``ready``: ``{"file": GLOB}`` (under the run's ``out``) or ``{"topic": NAME}`` (listed
    by ``topic_command``) or ``{"delay": SECONDS}``; ``wait: true`` marks the step whose end
    ends the run (default: the last step).
    """

    name: str
    command: list[str] | str
    ready: dict[str, Any] | None = None
    wait: bool = False


@dataclass(frozen=True)
class Algorithm:
    """One SLAM program (or ROS recipe), its parameter axes and outputs."""

    name: str
    command: list[str] | str | None
    recipe: tuple[Step, ...] = ()
    params: dict[str, list[Any]] = field(default_factory=dict)
    config_template: Path | None = None
    config_overrides: dict[str, Any] = field(default_factory=dict)
    env: dict[str, str] = field(default_factory=dict)
    map: Output | None = None
    trajectory: Output | None = None
    snapshots: Output | None = None
    quiet_period: float = 0.0
    topic_command: list[str] = field(default_factory=lambda: ["ros2", "topic", "list"])

    def variants(self) -> list[tuple[str, dict[str, Any]]]:
        """``(name, params)`` for the cross product of the parameter axes.

        Examples
        --------
        >>> a = Algorithm("x", ["true"], params={"n": [1, 2], "mode": ["a"]})
        >>> [v for v, _ in a.variants()]
        ['mode=a,n=1', 'mode=a,n=2']
        """
        if not self.params:
            return [("default", {})]
        names = sorted(self.params)
        out = []
        for combo in itertools.product(*(self.params[n] for n in names)):
            values = dict(zip(names, combo))
            out.append((",".join(f"{n}={v}" for n, v in values.items()), values))
        return out


@dataclass(frozen=True)
class SequenceSpec:
    """A sequence of a run config: the recording the programs read (``input``), with its
    optional ground truth."""

    name: str
    input: Path
    groundtruth: Path | None = None
    groundtruth_map: Path | None = None
    #: A generated sequence's recipe (``synth:``; :mod:`slamq.synth.benchmark`): its files
    #: are made before the runs that read them.
    generated: Generated | None = None
    #: The relations ground truth (Kümmerle et al. 2009; ``rel_*`` columns).
    relations: Path | None = None
    #: What reading a run's trajectory does when its timestamps go backwards: ``error``,
    #: ``sort`` or ``last`` (``unsorted`` of :func:`slamq.load_trajectory`).
    unsorted: str = "error"
    #: A real robot's log converted before the runs (``carmen:`` / ``bag:``;
    #: :mod:`slamq.runner.recorded`): ``input`` is its rawlog.
    recorded: Recorded | None = None


@dataclass(frozen=True)
class RunConfig:
    """A whole runner configuration (see the module docstring for the keys)."""

    sequences: tuple[SequenceSpec, ...]
    algorithms: tuple[Algorithm, ...]
    output: Path
    iterations: int = 1
    parallel: int = 1
    timeout: float | None = None
    startup_timeout: float = 60.0
    retries: int = 0
    grace: tuple[float, float] = (5.0, 5.0)
    min_poses: int = 2
    report: bool = True
    evaluate: dict[str, Any] = field(default_factory=dict)
    ros_domain_base: int = 10
    ros_master_base: int = 11311
    source: str = "<dict>"
    #: The folder relative paths of the config are read from (the config file's folder).
    base_dir: Path | None = None


def _where(source: str, key: str) -> str:
    return f"{source}: {key}"


def refuse_unknown(keys: Any, known: Any, where: str) -> None:
    """Raise a ParamError naming every key of ``keys`` not in ``known``, each with the
    closest known name when there is one (a typo must not silently change an experiment).

    Examples
    --------
    >>> try:
    ...     refuse_unknown({"fromat": "mrpt", "path": "x"}, ("path", "format"), "outputs.map")
    ... except ParamError as exc:
    ...     print(exc)
    outputs.map: unknown key 'fromat' (did you mean 'format'?); known: format, path
    """
    import difflib

    known = sorted(str(k) for k in known)
    bad = sorted(str(k) for k in keys if str(k) not in known)
    if not bad:
        return
    said = []
    for k in bad:
        close = difflib.get_close_matches(k, known, n=1, cutoff=0.6)
        said.append(f"{k!r}" + (f" (did you mean {close[0]!r}?)" if close else ""))
    raise ParamError(f"{where}: unknown key{'s' if len(bad) > 1 else ''} {', '.join(said)}; "
                     f"known: {', '.join(known)}")


def check_overrides(template: Path, overrides: dict[str, Any], where: str) -> None:
    """Refuse an ini override whose section the template lacks, or whose key is not in
    its section but close to one that is (a typo), each with the closest known name. A key
    the section does not have and that resembles none is added (programs read optional
    keys); ``+SECTION.key`` adds a section the template lacks on purpose. YAML templates and
    templates that cannot be read are checked when the run renders them.
    """
    import difflib

    if template.suffix.lower() in (".yaml", ".yml"):
        return
    try:
        text = template.read_text(errors="replace")
    except OSError:
        return
    sections: dict[str, set[str]] = {}
    current = None
    for line in text.splitlines():
        m = re.match(r"\s*\[(.+?)\]", line)
        if m:
            current = m.group(1)
            sections.setdefault(current, set())
            continue
        km = re.match(r"\s*([A-Za-z0-9_.\-]+)\s*=", line)
        if km and current is not None:
            sections[current].add(km.group(1))
    for name in overrides:
        if name.startswith("+") or "." not in name:
            continue  # added on purpose; or refused as not SECTION.key when rendered
        sec, key = name.rsplit(".", 1)
        if sec not in sections:
            close = difflib.get_close_matches(sec, list(sections), n=1, cutoff=0.6)
            hint = f"did you mean {close[0]}.{key}?" if close else \
                f"its sections: {', '.join(sections) or 'none'}"
            raise ParamError(f"{where}.config_overrides: {name}: {template.name} has no section "
                             f"[{sec}] ({hint}; write +{name} to add the section)")
        if key not in sections[sec]:
            close = difflib.get_close_matches(key, sorted(sections[sec]), n=1, cutoff=0.8)
            if close:
                raise ParamError(f"{where}.config_overrides: {name}: [{sec}] of "
                                 f"{template.name} has no key {key} (did you mean "
                                 f"{sec}.{close[0]}?)")


def _num(doc: dict, key: str, default: Any, source: str, kind: type = float,
         minimum: float = 0) -> Any:
    value = doc.get(key, default)
    if value is None:
        return None
    try:
        v = kind(value)
    except (TypeError, ValueError):
        raise ParamError(f"{_where(source, key)} must be a number, got {value!r}") from None
    if v < minimum:
        raise ParamError(f"{_where(source, key)} must be >= {minimum}, got {value!r}")
    return v


def _path(base: Path, value: Any, where: str) -> Path:
    if not isinstance(value, (str, os.PathLike)) or not str(value):
        raise ParamError(f"{where} must be a path, got {value!r}")
    p = Path(os.path.expanduser(str(value)))
    return p if p.is_absolute() else base / p


def _output(value: Any, where: str, formats: tuple[str, ...]) -> Output | None:
    if value is None:
        return None
    if isinstance(value, str):
        value = {"path": value}
    if not isinstance(value, dict) or "path" not in value:
        raise ParamError(f"{where} must be a glob or {{path: GLOB, format: ...}}")
    refuse_unknown(value, ("path", "format", "topic", "times"), where)
    fmt = str(value.get("format", "auto" if "auto" in formats else formats[0]))
    if fmt not in formats:
        raise ParamError(f"{where}.format must be one of {', '.join(formats)}, got {fmt!r}")
    times = value.get("times")
    if times is not None and (not isinstance(times, str) or not times):
        raise ParamError(f"{where}.times must be a path (one time per step), got {times!r}")
    return Output(str(value["path"]), fmt, value.get("topic"), times)


def _command(value: Any, where: str) -> list[str] | str:
    if isinstance(value, str) and value.strip():
        return value
    if isinstance(value, list) and value and all(isinstance(x, (str, int, float)) for x in value):
        return [str(x) for x in value]
    raise ParamError(f"{where} must be a non-empty string (shell) or list (no shell)")


def _algorithm(name: str, doc: Any, base: Path, source: str) -> Algorithm:
    where = f"{source}: algorithms.{name}"
    if not isinstance(doc, dict):
        raise ParamError(f"{where} must be a mapping")
    refuse_unknown(doc, {"command", "recipe", "params", "config_template", "config_overrides",
                         "env", "outputs", "quiet_period", "topic_command"}, where)
    if ("command" in doc) == ("recipe" in doc):
        raise ParamError(f"{where} needs exactly one of command or recipe")
    command = _command(doc["command"], f"{where}.command") if "command" in doc else None
    steps = []
    if "recipe" in doc:
        if not isinstance(doc["recipe"], list) or not doc["recipe"]:
            raise ParamError(f"{where}.recipe must be a non-empty list of steps")
        for i, s in enumerate(doc["recipe"]):
            if not isinstance(s, dict) or "command" not in s:
                raise ParamError(f"{where}.recipe[{i}] needs a command")
            refuse_unknown(s, ("name", "command", "ready", "wait"), f"{where}.recipe[{i}]")
            ready = s.get("ready")
            if ready is not None and (not isinstance(ready, dict) or len(ready) != 1
                                      or next(iter(ready)) not in ("file", "topic", "delay")):
                raise ParamError(f"{where}.recipe[{i}].ready must be one of "
                                 "{file: GLOB}, {topic: NAME}, {delay: SECONDS}")
            steps.append(Step(str(s.get("name", f"step{i}")),
                              _command(s["command"], f"{where}.recipe[{i}].command"),
                              ready, bool(s.get("wait", False))))
        if not any(s.wait for s in steps):
            steps[-1] = Step(steps[-1].name, steps[-1].command, steps[-1].ready, True)
    params = doc.get("params") or {}
    if not isinstance(params, dict):
        raise ParamError(f"{where}.params must be a mapping name -> value or list of values")
    axes = {}
    for k, v in params.items():
        values = v if isinstance(v, list) else [v]
        if not values:
            raise ParamError(f"{where}.params.{k} is an empty list")
        axes[str(k)] = values
    outputs = doc.get("outputs") or {}
    if not isinstance(outputs, dict):
        raise ParamError(f"{where}.outputs must be a mapping")
    refuse_unknown(outputs, ("map", "trajectory", "snapshots"), f"{where}.outputs")
    template = doc.get("config_template")
    overrides = doc.get("config_overrides") or {}
    if not isinstance(overrides, dict):
        raise ParamError(f"{where}.config_overrides must be a mapping KEY -> value")
    if template:
        check_overrides(_path(base, template, f"{where}.config_template"),
                        {str(k): v for k, v in overrides.items()}, where)
    topic_cmd = doc.get("topic_command", ["ros2", "topic", "list"])
    return Algorithm(
        name=name, command=command, recipe=tuple(steps), params=axes,
        config_template=_path(base, template, f"{where}.config_template") if template else None,
        config_overrides={str(k): v for k, v in overrides.items()},
        env={str(k): str(v) for k, v in (doc.get("env") or {}).items()},
        map=_output(outputs.get("map"), f"{where}.outputs.map", MAP_FORMATS),
        trajectory=_output(outputs.get("trajectory"), f"{where}.outputs.trajectory",
                           TRAJECTORY_FORMATS),
        snapshots=_output(outputs.get("snapshots"), f"{where}.outputs.snapshots", MAP_FORMATS),
        quiet_period=_num(doc, "quiet_period", 0.0, where),
        topic_command=[str(x) for x in topic_cmd] if isinstance(topic_cmd, list)
        else str(topic_cmd).split(),
    )


_TRUTH_KEYS = ("groundtruth", "groundtruth_map", "relations", "unsorted")


def _existing(base: Path, value: Any, where: str, what: str) -> Path:
    path = _path(base, value, where)
    if not path.exists():
        raise ParamError(f"{where}: {path}: no such {what}")
    return path


def _sequence(name: str, s: Any, base: Path, output: Path, source: str
              ) -> list[SequenceSpec]:
    """The sequences of one ``sequences:`` entry (a generated recipe gives several)."""
    if isinstance(s, str):
        s = {"input": s}
    w = f"{source}: sequences.{name}"
    if isinstance(s, dict) and "synth" in s:
        if set(s) != {"synth"}:
            raise ParamError(f"{w}: a generated sequence has only the key synth")
        return [SequenceSpec(g.name, g.input, g.groundtruth, g.groundtruth_map, g)
                for g in expand(name, s["synth"], output, base, f"{w}.synth")]
    kinds = [k for k in ("input", *RECORDED_KINDS) if isinstance(s, dict) and k in s]
    if len(kinds) != 1:
        what = " and ".join(kinds) if kinds else "none"
        raise ParamError(f"{w} needs exactly one of input, carmen, bag (or a synth recipe); "
                         f"found {what}")
    kind = kinds[0]
    known = ("input",) if kind == "input" else RECORDED_KINDS[kind]
    refuse_unknown(s, (*known, *_TRUTH_KEYS), w)
    unsorted = s.get("unsorted", "error")
    if unsorted not in SETTINGS.unsorted.choices:
        raise ParamError(f"{w}.unsorted must be one of {', '.join(SETTINGS.unsorted.choices)},"
                         f" got {unsorted!r}")
    truth = {
        "groundtruth": _path(base, s["groundtruth"], f"{w}.groundtruth")
        if s.get("groundtruth") else None,
        "groundtruth_map": _path(base, s["groundtruth_map"], f"{w}.groundtruth_map")
        if s.get("groundtruth_map") else None,
        "relations": _existing(base, s["relations"], f"{w}.relations", "relations file")
        if s.get("relations") else None,
        "unsorted": unsorted,
    }
    if kind == "input":
        return [SequenceSpec(name, _path(base, s["input"], f"{w}.input"), **truth)]
    log = _existing(base, s[kind], f"{w}.{kind}",
                    "CARMEN log" if kind == "carmen" else "bag")
    if isinstance(s.get("motion_model"), dict):
        from slamq.synth.writers.rawlog import MOTION_MODEL

        refuse_unknown(s["motion_model"], MOTION_MODEL, f"{w}.motion_model")
    rec = parse_recorded(name, s, kind, log, output, w)
    return [SequenceSpec(name, rec.input, recorded=rec, **truth)]


def load_config(config: Any) -> RunConfig:
    """Read a runner configuration from a YAML file, a dict or a :class:`RunConfig`.

    Relative paths are relative to the YAML file's folder (the current folder for a dict,
    or its ``base_dir`` key).

    Raises
    ------
    slamq.ParamError
        A missing or malformed key, named with the file.

    Examples
    --------
    >>> c = load_config({"output": "/tmp/out", "iterations": 2,
    ...     "sequences": {"s": {"input": "/data/s.rawlog"}},
    ...     "algorithms": {"a": {"command": ["echo", "{input}"], "params": {"n": [1, 2]}}}})
    >>> c.iterations, [v for v, _ in c.algorithms[0].variants()], str(c.sequences[0].input)
    (2, ['n=1', 'n=2'], '/data/s.rawlog')
    """
    if isinstance(config, RunConfig):
        return config
    if isinstance(config, (str, os.PathLike)):
        import yaml

        path = Path(config)
        try:
            doc = yaml.safe_load(path.read_text())
        except OSError as exc:
            raise ParamError(f"{path}: cannot read the run config ({exc.strerror or exc})") from exc
        except yaml.YAMLError as exc:
            raise ParamError(f"{path}: not valid YAML ({exc})".replace("\n", " ")) from exc
        base, source = path.resolve().parent, str(path)
    elif isinstance(config, dict):
        doc = dict(config)
        base = Path(doc.pop("base_dir", ".")).resolve()
        source = "<dict>"
    else:
        raise ParamError(f"run config must be a path or a dict, got {type(config).__name__}")
    if not isinstance(doc, dict):
        raise ParamError(f"{source}: the run config must be a mapping")
    known = {"sequences", "algorithms", "output", "iterations", "parallel", "timeout",
             "startup_timeout", "retries", "grace", "min_poses", "report", "evaluate",
             "ros_domain_base", "ros_master_base"}
    refuse_unknown(doc, known, source)
    seqs = doc.get("sequences")
    algos = doc.get("algorithms")
    if not isinstance(seqs, dict) or not seqs:
        raise ParamError(f"{source}: sequences must be a non-empty mapping name -> input")
    if not isinstance(algos, dict) or not algos:
        raise ParamError(f"{source}: algorithms must be a non-empty mapping")
    output = _path(base, doc.get("output", "slamq-runs"), f"{source}: output")
    sequences = [seq for name, s in seqs.items()
                 for seq in _sequence(str(name), s, base, output, source)]
    if len({s.name for s in sequences}) != len(sequences):
        raise ParamError(f"{source}: two sequences have the same name")
    grace = doc.get("grace", [5.0, 5.0])
    if not (isinstance(grace, list) and len(grace) == 2):
        raise ParamError(f"{source}: grace must be [seconds after SIGINT, after SIGTERM]")
    evaluate = doc.get("evaluate") or {}
    if not isinstance(evaluate, dict):
        raise ParamError(f"{source}: evaluate must be a mapping of evaluate_many keywords")
    return RunConfig(
        base_dir=base,
        sequences=tuple(sequences),
        algorithms=tuple(_algorithm(str(k), v, base, source) for k, v in algos.items()),
        output=output,
        iterations=_num(doc, "iterations", 1, source, int, 1),
        parallel=_num(doc, "parallel", 1, source, int, 1),
        timeout=_num(doc, "timeout", None, source),
        startup_timeout=_num(doc, "startup_timeout", 60.0, source),
        retries=_num(doc, "retries", 0, source, int, 0),
        grace=(float(grace[0]), float(grace[1])),
        min_poses=_num(doc, "min_poses", 2, source, int, 0),
        report=bool(doc.get("report", True)),
        evaluate=dict(evaluate),
        ros_domain_base=_num(doc, "ros_domain_base", 10, source, int, 0),
        ros_master_base=_num(doc, "ros_master_base", 11311, source, int, 1),
        source=source,
    )
