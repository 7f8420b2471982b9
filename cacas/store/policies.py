"""Adaptation runs (CACAA, Table III) and policy checkpoints (atomic files, sha256, roll-back)."""

from __future__ import annotations

import json
import time
from typing import Sequence

import pandas as pd

from cacas.errors import AlreadyAdapted, CacasError
from cacas.store import files, recovery
from cacas.store import validate as v
from cacas.store.base import PolicyVersion


#: (file, inode, size, modification and change times, recorded sha256) -> whether the file's bytes
#: match it (:meth:`PoliciesMixin.damaged_policy_files`), for the life of the process.
_CHECKED: dict[tuple, bool] = {}
#: A file changed less than this long ago (its status change time, ctime) is read again at every
#: check rather than remembered: a rewrite within the file system's time granularity (2 s on FAT;
#: 1 s on HFS+ and some network shares) would leave its times as they were.
_SETTLED_NS = 2_000_000_000


class PoliciesMixin:
    """Method group of StudyStore: adaptation runs and policy checkpoints."""

    # --- adaptation runs and policy checkpoints (CACAA, Table III) -----------------------------
    def record_adaptation(self, participant: str, day: int, method: str, parameters: dict,
                          duration_s: float, metrics: dict, policy_version: int | None = None) -> int:
        """Record an adaptation run that used days 1..``day`` (0: the initial policy) with
        ``method``; ``parameters`` and ``metrics`` are JSON-able dicts (metrics key
        "preference_accuracy" feeds daily.csv), ``policy_version`` the checkpoint it produced.
        Returns the run's id."""
        method, day = v.method(method), v.integer(day, "day", 0)  # 0: the initial policy
        run = self._adaptation_row(parameters, duration_s, metrics)
        code = str(participant).strip()

        def fn(c):
            pid = self._pid(c, participant)
            if day:
                self._day_row(c, pid, code, day)
            return self._insert_adaptation(c, pid, code, day, method, run,
                                           self._check_version(c, pid, code, policy_version))
        return self._write(fn)

    def note_adaptation_started(self, participant: str, day: int, method: str) -> None:
        """Log (event ``adapt_start``) that an adaptation of ``day`` with ``method`` began: an
        adaptation that saves nothing, because the app was stopped during it, leaves this note
        (see :func:`cacas.study_day.unfinished_adaptation`)."""
        method, day, code = v.method(method), v.integer(day, "day", 1), v.code(participant)

        def fn(c):
            self._day_row(c, self._pid(c, code), code, day)
            self._event(c, "adapt_start", code, day=day, method=method)
        self._write(fn)

    @staticmethod
    def _adaptation_row(parameters: dict, duration_s: float, metrics: dict) -> tuple:
        return (v.json_dict(parameters, "parameters"), v.number(duration_s, "duration_s", 0),
                v.json_dict(metrics, "metrics"))

    def _insert_adaptation(self, c, pid: int, code: str, day: int, method: str, run: tuple,
                           version: int | None) -> int:
        params_json, duration, metrics_json = run
        cur = c.execute("INSERT INTO adaptations (participant_id, day, method, parameters, duration_s, "
                        "metrics, policy_version, created_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                        (pid, day, method, params_json, duration, metrics_json, version, v.now()))
        self._event(c, "record_adaptation", code, day=day, method=method, id=cur.lastrowid,
                    duration_s=duration, policy_version=version)
        return cur.lastrowid

    def adaptations_frame(self, participant: str | None = None, study: str | None = None) -> pd.DataFrame:
        """adaptations.csv: participant, day, method, parameters (JSON), duration_s, metrics
        (JSON), policy_version, created_at, preference_accuracy (from metrics; NaN if absent)."""
        sql = ("SELECT p.code AS participant, a.day, a.method, a.parameters, a.duration_s, a.metrics, "
               "a.policy_version, a.created_at FROM adaptations a JOIN participants p ON p.id = a.participant_id "
               "JOIN studies s ON s.id = p.study_id")
        where, params = [], []
        if participant is not None:
            where.append("p.code = ?")
            params.append(str(participant).strip())
        if study is not None:
            where.append("s.name = ?")
            params.append(study)
        df = self._frame(sql + (" WHERE " + " AND ".join(where) if where else "") + " ORDER BY a.id", params)
        df["policy_version"] = df["policy_version"].astype("Int64")
        df["duration_s"] = df["duration_s"].astype("float64")
        df["preference_accuracy"] = [pd.to_numeric(json.loads(m).get("preference_accuracy"), errors="coerce")
                                     for m in df["metrics"]]
        df["preference_accuracy"] = df["preference_accuracy"].astype("float64")
        return df

    def save_policy(self, participant: str, day: int, method: str, data: bytes, activate: bool = True) -> int:
        """Store a policy checkpoint adapted from days 1..``day`` (0: the initial policy).

        The bytes go to ``policies/<participant>/day<d>-<method>-<sha8>.pt`` beside the database,
        written atomically (tmp + fsync + rename); the row records its sha256. Returns the new
        version number (1..n per participant); with ``activate`` it becomes the policy in force.
        """
        method, day = v.method(method), v.integer(day, "day", 0)
        code = v.code(participant)

        def fn(c, rel, digest, size):
            return self._insert_policy(c, self._pid(c, code), code, day, method, rel, digest, size, activate)
        return self._with_policy_file(code, day, method, data, fn)

    def save_adapted_policy(self, participant: str, day: int, method: str, data: bytes, parameters: dict,
                            duration_s: float, metrics: dict, initial_metrics: dict | None = None) -> int:
        """The end of a day's adaptation (Table III step 2), all or nothing: the policy adapted
        from days 1..``day`` saved and put in force, and its run recorded, in one transaction.
        Refused, nothing written, when ``day`` is no longer the participant's latest day or a
        policy was adapted after it meanwhile (another tab or server adapted it: a second run
        would adapt the same data twice and replace the policy in force during the next day).
        ``initial_metrics``: the initial policy's scores (Fig. 4's day 1), recorded as the
        method's day-0 run unless it has one. Returns the new version."""
        method, day = v.method(method), v.integer(day, "day", 1)
        code = v.code(participant)
        run = self._adaptation_row(parameters, duration_s, metrics)
        initial = None if initial_metrics is None else self._adaptation_row({"initial": True}, 0.0, initial_metrics)

        def fn(c, rel, digest, size):
            pid = self._pid(c, code)
            self._day_row(c, pid, code, day)
            latest = c.execute("SELECT MAX(day) FROM days WHERE participant_id = ?", (pid,)).fetchone()[0]
            if latest != day:
                raise CacasError(f"day {day} of participant {code} cannot be adapted any more: day {latest} has "
                                 "begun; nothing was saved")
            done = c.execute("SELECT MAX(version) FROM policies WHERE participant_id = ? AND day = ?",
                             (pid, day)).fetchone()[0]
            if done is not None:
                raise AlreadyAdapted(f"day {day} of participant {code} is adapted already (policy version {done}, "
                                 "from another tab or server?); nothing was saved")
            if initial is not None and c.execute("SELECT 1 FROM adaptations WHERE participant_id = ? AND day = 0 "
                                                 "AND method = ?", (pid, method)).fetchone() is None:
                self._insert_adaptation(c, pid, code, 0, method, initial, None)
            version = self._insert_policy(c, pid, code, day, method, rel, digest, size, activate=True)
            self._insert_adaptation(c, pid, code, day, method, run, version)
            return version
        return self._with_policy_file(code, day, method, data, fn)

    def _with_policy_file(self, code: str, day: int, method: str, data: bytes, fn):
        """Write the checkpoint file of ``data``, then ``fn(c, rel, digest, size)`` in a write
        transaction; the file is removed again if the transaction fails (no file without its row),
        and by the next opening for writing if the process is killed in between
        (:func:`cacas.store.recovery.saving`)."""
        if not isinstance(data, (bytes, bytearray)) or not data:
            raise CacasError("policy data must be non-empty bytes (ReshapedPolicy.to_bytes())")
        digest = files.sha256(bytes(data))
        rel = f"{code}/day{day}-{method}-{digest[:8]}.pt"

        def check(c):
            pid = self._pid(c, code)
            if day:
                self._day_row(c, pid, code, day)
        self._read(check)  # refuse before writing a file
        if self.readonly:
            raise CacasError(f"{self.path}: opened read-only; nothing was written")
        existed = (self.policy_dir / rel).exists()  # the same bytes, which another database beside may name
        with recovery.saving(self.policy_dir) as mark:  # killed before the commit: deleted at the next opening
            mark(self.policy_dir / rel)
            files.atomic_write(self.policy_dir / rel, bytes(data))
            try:
                return self._write(lambda c: fn(c, rel, digest, len(data)))
            except BaseException:  # e.g. the participant was removed meanwhile: no file without its row
                if not existed:
                    self._drop_unreferenced(rel)
                raise

    def _insert_policy(self, c, pid: int, code: str, day: int, method: str, rel: str, digest: str, size: int,
                       activate: bool) -> int:
        version = c.execute("SELECT COALESCE(MAX(version), 0) + 1 FROM policies WHERE participant_id = ?",
                            (pid,)).fetchone()[0]
        c.execute("INSERT INTO policies (participant_id, version, day, method, path, sha256, size, created_at) "
                  "VALUES (?, ?, ?, ?, ?, ?, ?, ?)", (pid, version, day, method, rel, digest, size, v.now()))
        if activate:
            c.execute("UPDATE participants SET active_policy = ?, updated_at = ? WHERE id = ?", (version, v.now(), pid))
        self._event(c, "save_policy", code, version=version, day=day, method=method, sha256=digest, active=activate)
        return version

    def _drop_unreferenced(self, rel: str) -> None:
        """Delete the checkpoint file ``rel`` (and its folder, if left empty) unless a policy
        version names it."""
        named = self._read(lambda c: c.execute("SELECT 1 FROM policies WHERE path = ?", (rel,)).fetchone())
        if named is None:
            path = self.policy_dir / rel
            try:
                path.unlink(missing_ok=True)
                path.parent.rmdir()
            except OSError:  # the folder holds other files: keep it
                pass

    def _policy_rows(self, c, pid: int, where: str = "", params: Sequence = ()) -> list[PolicyVersion]:
        active = c.execute("SELECT active_policy FROM participants WHERE id = ?", (pid,)).fetchone()[0]
        rows = c.execute("SELECT version, day, method, path, sha256, size, created_at FROM policies "
                         f"WHERE participant_id = ? {where} ORDER BY version", (pid, *params)).fetchall()
        return [PolicyVersion(r[0], r[1], r[2], self.policy_dir / r[3], r[4], r[5], r[6], r[0] == active)
                for r in rows]

    def policy_versions(self, participant: str) -> list[PolicyVersion]:
        """All policy checkpoints of a participant, oldest first (``active`` marks the one in force)."""
        return self._read(lambda c: self._policy_rows(c, self._pid(c, participant)))

    def active_policy(self, participant: str) -> PolicyVersion | None:
        """The checkpoint in force; None: the initial policy."""
        return next((p for p in self.policy_versions(participant) if p.active), None)

    def set_active_policy(self, participant: str, version: int | None) -> None:
        """Put a saved version in force (roll back or forward); None: back to the initial policy."""
        code = str(participant).strip()

        def fn(c):
            pid = self._pid(c, participant)
            ver = self._check_version(c, pid, code, version)
            c.execute("UPDATE participants SET active_policy = ?, updated_at = ? WHERE id = ?", (ver, v.now(), pid))
            self._event(c, "set_active_policy", code, version=ver)
        self._write(fn)

    def load_policy(self, participant: str, day: int | None = None, method: str = "cacas",
                    version: int | None = None) -> bytes:
        """The bytes of a checkpoint, after checking its sha256 (a mismatch or a missing file
        raises CacasError). Which one: ``version`` if given; else the latest of ``method`` saved
        for ``day``; else the active policy, or failing that the latest of ``method``."""
        code = str(participant).strip()

        def fn(c):
            pid = self._pid(c, participant)
            if version is not None:
                rows = self._policy_rows(c, pid, "AND version = ?", (v.integer(version, "policy version", 1),))
                what = f"version {version}"
            elif day is not None:
                rows = self._policy_rows(c, pid, "AND day = ? AND method = ?",
                                         (v.integer(day, "day", 0), v.method(method)))
                what = f"day {day} and method {method!r}"
            else:
                rows = [p for p in self._policy_rows(c, pid) if p.active] or \
                       self._policy_rows(c, pid, "AND method = ?", (method,))
                what = f"method {method!r}"
            if not rows:
                raise CacasError(f"participant {code} has no saved policy for {what}")
            return rows[-1]
        pv = self._read(fn)
        try:
            data = pv.path.read_bytes()
        except OSError:
            raise CacasError(f"{pv.path}: policy version {pv.version} of participant {code} is missing") from None
        if files.sha256(data) != pv.sha256:
            raise CacasError(f"{pv.path}: policy version {pv.version} of participant {code} does not match "
                             f"its recorded sha256 (the file was changed or damaged)")
        return data

    def missing_policy_files(self, study: str | None = None) -> list[str]:
        """Policy files the database names but the policies folder lacks (paths relative to it),
        e.g. before an export whose zip must hold them all."""
        return [rel for rel in self.policies_frame(study)["path"] if not (self.policy_dir / rel).is_file()]

    def damaged_policy_files(self, study: str | None = None) -> list[str]:
        """Policy files the database names that are there but do not match their recorded sha256
        (changed or damaged: :meth:`load_policy` refuses them, and so does the export's zip).
        The Results page asks on every run, so a file's answer is remembered while the file stays
        as it is: the same inode, size, modification time and status change time (ctime, which no
        program can set back, as ``touch -d`` or ``cp -p`` set the modification time), and only once
        that change is :data:`_SETTLED_NS` old, so a rewrite within the file system's time
        granularity cannot leave all of them as they were (safety audit L10: on size and
        modification time alone, a same-size rewrite was missed until the zip's download failed
        with the browser's bare "Failed to generate file for download")."""
        bad = []
        now = time.time_ns()
        for rel, digest in zip(*(self.policies_frame(study)[col] for col in ("path", "sha256"))):
            path = self.policy_dir / rel
            try:
                st = path.stat()
            except OSError:  # missing: missing_policy_files says so
                continue
            key = (str(path), st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns, digest)
            ok = _CHECKED.get(key)
            if ok is None:
                try:
                    ok = files.sha256(path.read_bytes()) == digest
                except OSError:
                    ok = False
                if now - max(st.st_mtime_ns, st.st_ctime_ns) >= _SETTLED_NS:
                    _CHECKED[key] = ok
            if not ok:
                bad.append(rel)
        return bad

    def policies_frame(self, study: str | None = None) -> pd.DataFrame:
        """policies.csv: participant, version, day, method, path (relative to the policies
        folder), sha256, size, created_at, active."""
        sql = ("SELECT p.code AS participant, o.version, o.day, o.method, o.path, o.sha256, o.size, o.created_at, "
               "CAST(o.version = p.active_policy AS INTEGER) AS active FROM policies o "
               "JOIN participants p ON p.id = o.participant_id JOIN studies s ON s.id = p.study_id")
        return self._frame(sql + (" WHERE s.name = ?" if study is not None else "") + " ORDER BY p.code, o.version",
                           (study,) if study is not None else ())
