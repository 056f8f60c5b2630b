"""Trajectory readers: TUM, KITTI, EuRoC, generic CSV / whitespace tables, ROS bags,
Cartographer pbstreams.

Text files are parsed by pandas' C parser when pandas is installed (about 0.25 s per
million TUM lines), else by :func:`numpy.loadtxt` (several times slower, same numbers).
"""

from __future__ import annotations

import dataclasses
import re
import stat
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Union

import numpy as np

from slamq import native
from slamq.errors import TrajectoryError
from slamq.models.trajectory import Trajectory, order_rows, yaw_to_quat
from slamq.params import SETTINGS
from slamq.sources.files import PathLike, is_bag

__all__ = ["load_trajectory", "order_rows", "parse_columns", "FORMATS", "ROLES"]

#: Formats :func:`load_trajectory` reads (``None`` = guess from the name and content).
FORMATS = SETTINGS.trajectory_format.choices
#: Column roles of the generic table reader.
ROLES = ("t", "x", "y", "z", "yaw", "qw", "qx", "qy", "qz")
Columns = Mapping[str, Union[str, int]]

# Header names recognised without a mapping (lower case, units in [] or () stripped).
_AUTO_NAMES = {
    "t": ("t", "time", "timestamp", "timestamps", "stamp", "timestamp_sec", "time_sec",
          "sec", "seconds", "%time", "field.header.stamp"),
    "x": ("x", "tx", "pos_x", "position_x", "p_x", "px"),
    "y": ("y", "ty", "pos_y", "position_y", "p_y", "py"),
    "z": ("z", "tz", "pos_z", "position_z", "p_z", "pz"),
    "yaw": ("yaw", "theta", "heading", "th", "a"),
    "qw": ("qw", "q_w", "orientation_w", "rw"),
    "qx": ("qx", "q_x", "orientation_x", "rx"),
    "qy": ("qy", "q_y", "orientation_y", "ry"),
    "qz": ("qz", "q_z", "orientation_z", "rz"),
}


def parse_columns(spec: str | Columns | None) -> dict | None:
    """A column mapping from ``"t=timestamp_sec,x=slam_x,y=slam_y"`` or ``"t,x,y,yaw"``.

    The second (positional) form names the role of each column in file order; ``_``
    skips a column. A mapping is returned checked and unchanged.

    Examples
    --------
    >>> parse_columns("t=timestamp_sec,x=slam_x,y=slam_y")
    {'t': 'timestamp_sec', 'x': 'slam_x', 'y': 'slam_y'}
    >>> parse_columns("t,_,x,y,yaw")
    {'t': 0, 'x': 2, 'y': 3, 'yaw': 4}
    """
    if spec is None:
        return None
    if isinstance(spec, str):
        parts = [p.strip() for p in spec.split(",") if p.strip()]
        if not parts:
            raise TrajectoryError(f"empty column mapping {spec!r}")
        if all("=" in p for p in parts):
            out: dict = {}
            for p in parts:
                role, _, col = p.partition("=")
                role, col = role.strip(), col.strip()
                out[role] = int(col) if re.fullmatch(r"\d+", col) else col
        elif any("=" in p for p in parts):
            raise TrajectoryError(
                f"column mapping {spec!r} mixes 'role=column' and positional roles"
            )
        else:
            out = {role: i for i, role in enumerate(parts) if role not in ("_", "-", "")}
        spec = out
    mapping = dict(spec)
    unknown = sorted(set(mapping) - set(ROLES))
    if unknown:
        raise TrajectoryError(
            f"unknown column role(s) {unknown}; roles are {', '.join(ROLES)}"
        )
    _check_roles(mapping, "column mapping")
    return mapping


def _check_roles(mapping: Mapping, where: str) -> None:
    if "x" not in mapping or "y" not in mapping:
        raise TrajectoryError(f"{where}: needs at least the 'x' and 'y' columns")
    quat = [r for r in ("qw", "qx", "qy", "qz") if r in mapping]
    if quat and len(quat) != 4:
        raise TrajectoryError(f"{where}: give all of qw, qx, qy, qz (got {quat})")
    if quat and "yaw" in mapping:
        raise TrajectoryError(f"{where}: give either yaw or the quaternion, not both")


# ---------------------------------------------------------------------- numeric parse
def _read_table(
    path: Path, *, sep: str, skiprows: int = 0, comment: str | None = "#"
) -> np.ndarray:
    """All data rows of a numeric text table as a float64 array (rows, cols).

    A regular table (``#`` comments, every row as long as the first, plain decimal numbers)
    is read by the Rust core in parallel (``slamq._core.read_table``, correctly rounded like
    Python's ``float``); anything else by pandas, whose errors name what is wrong."""
    import pandas as pd
    from pandas.errors import EmptyDataError, ParserError

    fast_sep = " " if sep == "ws" else sep
    if comment == "#" and len(fast_sep.encode()) == 1 and (sep == "ws" or not sep.isspace()):
        fast = native.read_table(path, fast_sep, skiprows)
        if fast is not None:
            return fast if fast.size else np.empty((0, 0))

    seps = [" ", r"\s+"] if sep == "ws" else [sep]
    last: Exception | None = None
    for s in seps:
        try:
            df = pd.read_csv(
                path, sep=s, comment=comment, header=None, engine="c",
                dtype=np.float64, skiprows=skiprows, skip_blank_lines=True,
                skipinitialspace=(s != " "),
            )
        except EmptyDataError:
            return np.empty((0, 0))
        except (ParserError, ValueError) as exc:
            last = exc
            continue
        arr = df.to_numpy(dtype=np.float64)
        if s == " " and len(seps) > 1 and np.isnan(arr).any():
            # Two spaces, tabs or trailing blanks: the strict single-space pass made
            # empty fields; the regex pass reads them correctly.
            last = None
            continue
        return arr
    if last is not None:
        msg = str(last).strip().splitlines()[-1]
        raise TrajectoryError(f"{path}: not a numeric table ({msg})")
    # sep=' ' found empty fields and \s+ failed without raising: cannot happen
    raise TrajectoryError(f"{path}: not a numeric table")  # pragma: no cover


def _nonempty(arr: np.ndarray, path: Path) -> None:
    if arr.size == 0:
        raise TrajectoryError(f"{path}: empty file (no poses)")


def _check_cols(arr: np.ndarray, path: Path, want: int, fmt: str, at_least: bool = False):
    ncol = arr.shape[1]
    if (ncol < want) if at_least else (ncol != want):
        raise TrajectoryError(
            f"{path}: a {fmt} file needs {'at least ' if at_least else ''}{want} "
            f"numbers per row, found {ncol}"
        )
    bad = np.isnan(arr[:, :want]).any(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0]) + 1
        raise TrajectoryError(f"{path}: missing or NaN value in data row {row}")


# ---------------------------------------------------------------------- row order
def _build(
    path: Path,
    t: np.ndarray,
    pos: np.ndarray,
    quat: np.ndarray | None,
    unsorted: str,
    meta: dict | None = None,
) -> Trajectory:
    keep = order_rows(t, unsorted)
    if keep.shape[0] != t.shape[0] or not np.array_equal(keep, np.arange(t.shape[0])):
        t, pos = t[keep], pos[keep]
        quat = None if quat is None else quat[keep]
    return Trajectory(t, pos, quat, source=str(path), meta=meta or {})


# ---------------------------------------------------------------------- formats
def read_tum(path: PathLike, *, unsorted: str = "error") -> Trajectory:
    """Read a TUM file: ``timestamp x y z qx qy qz qw`` per line, ``#`` comments.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "t.txt"
    >>> _ = p.write_text("# t x y z qx qy qz qw\\n0.0 1 2 0 0 0 0 1\\n0.1 2 2 0 0 0 0 1\\n")
    >>> read_tum(p).positions[:, 0].tolist()
    [1.0, 2.0]
    """
    path = Path(path)
    # The common case in one pass: a regular TUM file whose poses the Trajectory checks
    # accept, parsed by the Rust core straight into the Trajectory's arrays (normalised
    # as the constructor does). Anything else is read below, and its errors raised there.
    fast = native.read_tum(path)
    if fast is not None:
        return Trajectory._from_checked(*fast, source=str(path), meta={"format": "tum"})
    arr = _read_table(path, sep="ws")
    _nonempty(arr, path)
    _check_cols(arr, path, 8, "TUM")
    quat = arr[:, [7, 4, 5, 6]]
    return _build(path, arr[:, 0], arr[:, 1:4], quat, unsorted, {"format": "tum"})


def read_kitti(path: PathLike) -> Trajectory:
    """Read a KITTI pose file: 12 numbers per line (a 3x4 pose matrix, row major).

    KITTI files have no timestamps: the pose index is used as the timestamp, so two
    KITTI files are matched by index. A row whose 3x3 block is not a rotation raises.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "k.txt"
    >>> _ = p.write_text("1 0 0 5 0 1 0 6 0 0 1 7\\n")
    >>> tr = read_kitti(p)
    >>> tr.timestamps.tolist(), tr.positions.tolist()
    ([0.0], [[5.0, 6.0, 7.0]])
    """
    path = Path(path)
    arr = _read_table(path, sep="ws")
    _nonempty(arr, path)
    _check_cols(arr, path, 12, "KITTI")
    tr = Trajectory.from_matrices(arr.reshape(-1, 3, 4), source=str(path))
    tr.meta["format"] = "kitti"
    return tr


def read_euroc(path: PathLike, *, unsorted: str = "error") -> Trajectory:
    """Read an EuRoC ground-truth CSV (``#timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z, ...``).

    Timestamps are nanoseconds and become seconds (divided by 1e9, as evo does).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "data.csv"
    >>> _ = p.write_text("#timestamp,p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],"
    ...                  "q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []\\n"
    ...                  "1500000000,1,2,3,1,0,0,0\\n")
    >>> read_euroc(p).timestamps.tolist()
    [1.5]
    """
    path = Path(path)
    arr = _read_table(path, sep=",")
    _nonempty(arr, path)
    _check_cols(arr, path, 8, "EuRoC", at_least=True)
    t = np.divide(arr[:, 0], 1e9)
    return _build(path, t, arr[:, 1:4], arr[:, 4:8], unsorted, {"format": "euroc"})


def _first_line(path: Path, comment: bool = False) -> tuple[str, int]:
    """The first non-blank line (and its index); skips '#' lines when ``comment``."""
    with open(path, encoding="utf-8-sig", errors="replace") as f:
        for i, line in enumerate(f):
            s = line.strip()
            if not s or (comment and s.startswith("#")):
                continue
            return s, i
    return "", -1


def _split(line: str, sep: str) -> list[str]:
    if sep == "ws":
        return line.split()
    return [c.strip() for c in line.split(sep)]


def _header(path: Path, sep: str | None) -> tuple[list[str], int, str]:
    """The header cells, the header's line index (-1: none) and the separator.

    The header is the first line that is neither blank nor a ``#`` comment when it is
    not numeric; else the last ``#`` comment line above the first data row when it has
    as many cells as that row (``# timestamp x y ...``, EuRoC's ``#timestamp,...``).
    """
    last_comment: tuple[str, int] | None = None
    with open(path, encoding="utf-8-sig", errors="replace") as f:
        for i, line in enumerate(f):
            s = line.strip()
            if not s:
                continue
            if s.startswith("#"):
                last_comment = (s, i)
                continue
            sep = sep or _guess_sep(s)
            cells = _split(s, sep)
            if not all(_is_number(c) for c in cells if c != ""):
                return cells, i, sep
            if last_comment is not None:
                ccells = _split(last_comment[0].lstrip("#").strip(), sep)
                if len(ccells) == len(cells) and not any(_is_number(c) for c in ccells):
                    return ccells, last_comment[1], sep
            return [], -1, sep
    raise TrajectoryError(f"{path}: empty file (no poses)")


def _guess_sep(line: str) -> str:
    if "," in line:
        return ","
    if ";" in line:
        return ";"
    return "ws"


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def _norm_name(name: str) -> str:
    name = re.sub(r"[\[(].*?[\])]", "", name).strip().lstrip("#").strip().lower()
    return name


def read_table(
    path: PathLike,
    columns: str | Columns | None = None,
    *,
    sep: str | None = None,
    unsorted: str = "error",
    by_index: bool = False,
) -> Trajectory:
    """Read a CSV or whitespace table with a column mapping.

    Parameters
    ----------
    path : str or Path
    columns : mapping or str, optional
        Role -> column, where a column is a header name or a 0-based index; roles are
        ``t`` (seconds), ``x``, ``y``, ``z``, and either ``yaw`` (radians about z) or
        all of ``qw, qx, qy, qz``. ``"t,x,y,yaw"`` names the roles of the columns in
        order. A table without ``t`` is refused unless ``by_index`` (then the row index
        is the timestamp, and poses are paired by row number); without ``z`` z = 0;
        without an orientation the identity (``meta["orientation"]`` is False).
        ``None``: guess from the header (``t/time/timestamp``, ``x``, ``y``, ``z``,
        ``yaw/theta``, ``qx``...).
    sep : str, optional
        ``","``, ``";"``, ``"\\t"`` or ``"ws"`` (any whitespace); guessed by default.
    unsorted : {"error", "last", "sort"}
        What to do when timestamps go backwards: raise, keep the rows after the last
        restart of the log, or sort by time (stable).
    by_index : bool, default False
        Accept a table without a time column: row ``i`` gets timestamp ``i`` seconds.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "log.csv"
    >>> _ = p.write_text("timestamp_sec,slam_x,slam_y,gt_x,gt_y\\n0,0,0,0,0\\n5,1,0,1.1,0\\n")
    >>> tr = read_table(p, {"t": "timestamp_sec", "x": "slam_x", "y": "slam_y"})
    >>> tr.positions[:, 0].tolist()
    [0.0, 1.0]
    """
    path = Path(path)
    mapping = parse_columns(columns) if columns is not None else None
    cells, header_idx, sep = _header(path, sep)
    has_header = header_idx >= 0
    names = [_norm_name(c) for c in cells] if has_header else []
    if mapping is None:
        if not has_header:
            raise TrajectoryError(
                f"{path}: no header to find the columns in; pass columns= (CLI --columns, "
                "e.g. 't,x,y,yaw' or 't=0,x=1,y=2')"
            )
        mapping = {}
        for role, aliases in _AUTO_NAMES.items():
            for i, n in enumerate(names):
                if n in aliases:
                    mapping[role] = i
                    break
        if "yaw" in mapping and all(r in mapping for r in ("qw", "qx", "qy", "qz")):
            del mapping["yaw"]
        elif not all(r in mapping for r in ("qw", "qx", "qy", "qz")):
            for r in ("qw", "qx", "qy", "qz"):
                mapping.pop(r, None)
        try:
            _check_roles(mapping, str(path))
        except TrajectoryError:
            raise TrajectoryError(
                f"{path}: cannot tell the x and y columns from the header "
                f"{cells}; pass columns= (CLI --columns / --gt-columns, e.g. "
                "'t=time,x=pos_x,y=pos_y')"
            ) from None
    index: dict[str, int] = {}
    for role, col in mapping.items():
        if isinstance(col, (int, np.integer)) and not isinstance(col, bool):
            index[role] = int(col)
            continue
        key = _norm_name(str(col))
        if key not in names:
            raise TrajectoryError(
                f"{path}: no column {col!r} for {role!r}; the header has {cells}"
            )
        index[role] = names.index(key)
    arr = _read_table(path, sep=sep, skiprows=header_idx + 1, comment="#")
    _nonempty(arr, path)
    ncol = arr.shape[1]
    for role, i in index.items():
        if i >= ncol:
            raise TrajectoryError(
                f"{path}: column {i} for {role!r} does not exist ({ncol} columns)"
            )
    used = sorted(set(index.values()))
    bad = np.isnan(arr[:, used]).any(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0]) + 1
        raise TrajectoryError(f"{path}: missing or NaN value in data row {row}")
    n = arr.shape[0]
    if "t" not in index and not by_index:
        raise TrajectoryError(
            f"{path}: no time column, so poses cannot be paired by time; name it (columns= "
            "'t=...', CLI --columns) or pair poses by row number with by_index=True (CLI "
            "--by-index)")
    t = arr[:, index["t"]] if "t" in index else np.arange(n, dtype=np.float64)
    pos = np.zeros((n, 3))
    pos[:, 0] = arr[:, index["x"]]
    pos[:, 1] = arr[:, index["y"]]
    if "z" in index:
        pos[:, 2] = arr[:, index["z"]]
    quat = None
    if "yaw" in index:
        quat = yaw_to_quat(arr[:, index["yaw"]])
    elif "qw" in index:
        quat = arr[:, [index["qw"], index["qx"], index["qy"], index["qz"]]]
    meta = {"format": "csv", "columns": {r: (names[i] if names else i) for r, i in index.items()},
            "orientation": quat is not None, "by_index": "t" not in index}
    return _build(path, t, pos, quat, unsorted, meta)


def _read_bag(path: Path, topic: str | None) -> Trajectory:
    from slamq.sources.bag_poses import read_bag_trajectory

    return read_bag_trajectory(path, topic=topic)


def _read_pbstream(path: Path, topic: str | None) -> Trajectory:
    from slamq.sources.pbstream import read_pbstream_trajectory

    if topic is None:
        return read_pbstream_trajectory(path)
    if not re.fullmatch(r"-?\d+", topic.strip()):
        raise TrajectoryError(f"{path}: for a pbstream, topic is a trajectory id, not {topic!r}")
    return read_pbstream_trajectory(path, int(topic))


def _mrpt_pose_log(path: Path, rows: int = 50) -> bool:
    """Whether an 8-column file is an MRPT pose log (``rbpf-slam``'s ``index x y z yaw pitch
    roll t``) rather than TUM (``t x y z qx qy qz qw``): its first column counts the rows
    from 0 and its last holds a time, not a quaternion's w (some ``|value| > 1.5``)."""
    first: list[float] = []
    last: list[float] = []
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                s = line.strip()
                if not s or s[0] in "#%":
                    continue
                cells = s.split()
                if len(cells) != 8:
                    return False
                first.append(float(cells[0]))
                last.append(float(cells[7]))
                if len(first) >= rows:
                    break
    except (OSError, ValueError):
        return False
    return bool(first) and first == [float(i) for i in range(len(first))] and \
        max(abs(v) for v in last) > 1.5


def _guess_format(path: Path) -> str:
    if is_bag(path):
        return "bag"
    if path.suffix.lower() == ".pbstream":
        return "pbstream"
    raw, idx = _first_line(path)
    if idx < 0:
        raise TrajectoryError(f"{path}: empty file (no poses)")
    low = raw.lower()
    if low.startswith("#timestamp") or "p_rs_r_x" in low:
        return "euroc"
    data, didx = _first_line(path, comment=True)
    if didx < 0:
        raise TrajectoryError(f"{path}: empty file (no poses, only comments)")
    data = data.split("#", 1)[0].strip()  # a trailing comment, as the readers allow
    sep = _guess_sep(data)
    cells = _split(data, sep)
    if sep == "ws" and all(_is_number(c) for c in cells):
        if len(cells) == 8:
            return "mrpt" if _mrpt_pose_log(path) else "tum"
        if len(cells) == 12:
            return "kitti"
    if not all(_is_number(c) for c in cells):
        return "csv"  # a header line
    if _header(path, None)[1] >= 0:
        return "csv"  # a '# name name ...' comment header with one name per column
    raise TrajectoryError(
        f"{path}: cannot tell the format ({len(cells)} numbers per row, not TUM's 8 or "
        f"KITTI's 12); pass format= and columns= (e.g. columns='t,x,y,yaw')"
    )


def load_trajectory(
    path: PathLike,
    *,
    format: str | None = None,
    columns: str | Columns | None = None,
    topic: str | None = None,
    unsorted: str = "error",
    by_index: bool = False,
) -> Trajectory:
    """Read a trajectory file (or ROS bag) into a :class:`Trajectory`.

    Parameters
    ----------
    path : str or Path
        A TUM, KITTI, EuRoC or CSV/whitespace table file, a ROS1/ROS2 bag
        (``.bag``, ``.mcap``, ``.db3`` or a folder with ``metadata.yaml``), or a
        Cartographer ``.pbstream`` (its trajectory node poses).
    format : {"tum", "kitti", "euroc", "csv", "mrpt", "bag", "pbstream"}, optional
        Guessed when omitted: bags and pbstreams by name; ``#timestamp`` headers are
        EuRoC; a header line means CSV; 8 numbers a row TUM, 12 KITTI, except an MRPT pose
        log (``rbpf-slam``'s ``log_estimated_path.txt``: ``index x y z yaw pitch roll t``,
        its first column counting the rows from 0 and its last a time), read by
        :func:`slamq.sources.mrpt.read_mrpt_path` (also ``graphslam-engine``'s graphs and
        ``icp-slam``'s index-timed logs with ``format="mrpt"``). ``columns`` implies
        ``"csv"``.
    columns : mapping or str, optional
        For tables: role -> column name or 0-based index, see :func:`read_table`.
        The slam_comparison_tools pose logs load with
        ``columns={"t": "timestamp_sec", "x": "slam_x", "y": "slam_y"}`` (and
        ``"x": "gt_x", "y": "gt_y"`` for their ground truth).
    topic : str, optional
        Bag topic (PoseStamped, PoseWithCovarianceStamped, Odometry, TransformStamped,
        or ``/tf`` as ``"/tf:parent->child"``), see ``slamq.sources.bag_poses.read_bag_trajectory``;
        for a pbstream the trajectory id (default ``"0"``).
    unsorted : {"error", "last", "sort"}
        Timestamps that go backwards raise by default; ``"last"`` keeps the rows after
        the last restart of the log, ``"sort"`` sorts them (stable).
    by_index : bool, default False
        Accept a table without a time column, pairing poses by row number (see
        :func:`read_table`); refused otherwise.

    Raises
    ------
    TrajectoryError
        Missing or empty file, unknown format, wrong column count, non-numeric or NaN
        values, non-monotonic timestamps; the message names the file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.sources.trajectories import load_trajectory
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "est.txt"
    >>> _ = p.write_text("1.0 0 0 0 0 0 0 1\\n1.1 0.5 0 0 0 0 0 1\\n")
    >>> tr = load_trajectory(p)
    >>> len(tr), tr.meta["format"]
    (2, 'tum')
    """
    path = Path(path)
    if format is not None:
        format = format.lower()
        if format not in FORMATS:
            raise TrajectoryError(
                f"{path}: unknown trajectory format {format!r} (one of {', '.join(FORMATS)})"
            )
    if unsorted not in SETTINGS.unsorted.choices:
        raise TrajectoryError(f"unsorted must be 'error', 'last' or 'sort', not {unsorted!r}")
    if not path.exists():
        raise TrajectoryError(f"{path}: no such file")
    if format == "bag" or (format is None and is_bag(path)):
        return _read_bag(path, topic)
    if path.is_dir():
        raise TrajectoryError(f"{path}: is a folder, not a trajectory file or bag")
    _check_regular(path)
    if columns is not None and format in (None, "csv"):
        return read_table(path, columns, unsorted=unsorted, by_index=by_index)
    if format is None:
        format = _guess_format(path)
    if format == "tum":
        return read_tum(path, unsorted=unsorted)
    if format == "kitti":
        return read_kitti(path)
    if format == "euroc":
        return read_euroc(path, unsorted=unsorted)
    if format == "pbstream":
        return _read_pbstream(path, topic)
    if format == "mrpt":
        from slamq.sources.mrpt import read_mrpt_path

        traj = read_mrpt_path(path, unsorted=unsorted)
        return dataclasses.replace(traj, meta={**traj.meta, "format": "mrpt"})
    if format == "csv":
        return read_table(path, columns, unsorted=unsorted, by_index=by_index)
    raise TrajectoryError(f"{path}: columns= only applies to format 'csv'")


def load_pair(traj: Path | str, gt: Path | str, unsorted: str = "error") -> tuple[Any, Any]:
    """Load estimate and ground truth (``slamq.Trajectory``); a paired pose log
    (one CSV with ``slam_x ... gt_x`` columns, see ``paired_columns``) gives both."""
    traj, gt = Path(traj), Path(gt)
    mappings = paired_mappings(traj) if traj == gt else None
    if mappings is None:
        return (
            load_trajectory(traj, unsorted=unsorted),
            load_trajectory(gt, unsorted=unsorted),
        )
    est_map, gt_map = mappings
    return (
        load_trajectory(traj, columns=est_map, unsorted=unsorted),
        load_trajectory(traj, columns=gt_map, unsorted=unsorted),
    )


def paired_mappings(path: Path | str) -> tuple[dict[str, str], dict[str, str]] | None:
    """The column mappings ``(estimate, ground truth)`` of a paired pose log (one CSV with
    ``slam_x ... gt_x`` columns, as slam_comparison_tools writes), else None.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "gmapping_pose_log.csv"
    >>> _ = p.write_text("timestamp_sec,slam_x,slam_y,gt_x,gt_y\\n0,0,0,0,0\\n")
    >>> paired_mappings(p)[1]
    {'t': 'timestamp_sec', 'x': 'gt_x', 'y': 'gt_y'}
    """
    path = Path(path)
    cols = paired_columns(path)
    if cols is None:
        return None
    est_prefix, gt_prefix = cols
    with open(path, encoding="utf-8", errors="replace") as fh:
        header = [c.strip() for c in fh.readline().split(",")]
    t_col = next((c for c in header if c.lower().startswith(("timestamp", "time", "t"))),
                 header[0])

    def mapping(prefix: str) -> dict[str, str]:
        m = {"t": t_col}
        for axis in ("x", "y", "z", "yaw", "qx", "qy", "qz", "qw"):
            name = next((c for c in header if c.lower() == prefix + axis), None)
            if name is not None:
                m[axis] = name
        return m

    return mapping(est_prefix), mapping(gt_prefix)


#: Estimate columns of a paired pose log (estimate and ground truth on one row).
_PAIRED_EST = ("slam_x", "est_x", "estimate_x")


def paired_columns(path: Path) -> tuple[str, str] | None:
    """For a paired pose log (estimate and ground truth on one row), the column prefixes.

    Returns ``(estimate_prefix, "gt_")`` (e.g. ``("slam_", "gt_")``) when the first line
    of a ``.csv`` file names ``gt_x`` and one of ``slam_x``/``est_x``/``estimate_x``.
    """
    if path.suffix.lower() != ".csv":
        return None
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            header = fh.readline()
    except OSError:
        return None
    cols = {c.strip().lower() for c in header.split(",")}
    if "gt_x" not in cols:
        return None
    for est in _PAIRED_EST:
        if est in cols:
            return est[:-1], "gt_"
    return None


#: A trajectory file larger than this is refused before it is read (about 40 M TUM poses).
MAX_TRAJECTORY_BYTES = 4 << 30


def _check_regular(path: Path) -> None:
    """A FIFO would block the reader for ever and /dev/zero never ends: only regular files
    of at most :data:`MAX_TRAJECTORY_BYTES` are read, as the map loader does."""
    try:
        st = path.stat()
    except (OSError, ValueError) as exc:
        raise TrajectoryError(f"{path}: cannot read: {getattr(exc, 'strerror', None) or exc}"
                              ) from None
    if not stat.S_ISREG(st.st_mode):
        raise TrajectoryError(f"{path}: not a regular file (a FIFO, device or socket), not a "
                              "trajectory file")
    if st.st_size > MAX_TRAJECTORY_BYTES:
        raise TrajectoryError(f"{path}: {st.st_size} bytes is too large for a trajectory file "
                              f"(limit {MAX_TRAJECTORY_BYTES})")
