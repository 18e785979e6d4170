"""The joints of a SPlisHSPlasH scene (PositionBasedDynamics' blocks, read by its own loader):
``HingeJoints`` and ``TargetVelocityMotorHingeJoints`` -> sphkit's ``joints`` (hinges, with a
target-velocity motor; :class:`~sphkit.scene.schema.JointConfig`).

``bodyID1`` and ``bodyID2`` name ``RigidBodies[].id`` (a body without ``id`` is taken to have its
index). Each rigid body becomes ``meshes[k]`` with k its index in ``RigidBodies``, so a joint's
``bodies`` are those indices; a static body (a wall, ``isDynamic`` false) is fixed in space.

The motor's sign: PositionBasedDynamics' velocity constraint of a
``TargetVelocityMotorHingeJoint`` is ``w_1 - w_2 + target a = 0`` (``w_1``: the angular velocity
of bodyID1, ``a`` the axis turning with bodyID1), so bodyID1 turns at ``-target`` about the axis
relative to bodyID2; sphkit's motor drives ``(w_A - w_B) . a`` to ``target_velocity``, so with A
= bodyID1 and B = bodyID2 the target (and every value of ``targetSequence``) changes sign.
``targetSequence`` keeps its time / value pairs and ``repeatSequence`` becomes ``repeat``.
"""

from __future__ import annotations

from typing import Any

from sphkit.scene.splishsplash.reader import Reader

#: the joint blocks sphkit translates
JOINT_ARRAYS = ("HingeJoints", "TargetVelocityMotorHingeJoints")


def joints(rd: Reader, rigid: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """``HingeJoints`` and ``TargetVelocityMotorHingeJoints`` -> ``joints`` (module docstring)."""
    ids: dict[int, int] = {}
    for k, rb in enumerate(rigid):
        ids.setdefault(rd.integer(rb, "id", f"RigidBodies[{k}]", k), k)
    out = []
    for key in JOINT_ARRAYS:
        motor = key.startswith("TargetVelocity")
        for k, jd in enumerate(rd.array(key)):
            w = f"{key}[{k}]"
            known = {"bodyID1", "bodyID2", "position", "axis"}
            if motor:
                known |= {"target", "targetSequence", "repeatSequence"}
            rd.collect_unknown(jd, w, known, set())
            bodies = []
            for f in ("bodyID1", "bodyID2"):
                if jd.get(f) is None:
                    raise rd.error(f"{w}.{f}", None, "the id of a rigid body (RigidBodies[].id)")
                i = rd.integer(jd, f, w, 0)
                if i not in ids:
                    raise rd.error(f"{w}.{f}", i,
                                   f"the id of a rigid body (RigidBodies[].id: {sorted(ids)})")
                bodies.append(ids[i])
            entry: dict[str, Any] = {
                "type": "hinge", "bodies": bodies,
                "position": rd.vec3(jd, "position", w, [0.0, 0.0, 0.0]),
                "axis": rd.vec3(jd, "axis", w, [1.0, 0.0, 0.0]),
            }
            n = len(out)
            rd.origin[f"joints[{n}]"] = w
            rd.origin[f"joints[{n}].bodies"] = f"{w}.bodyID1/bodyID2"
            rd.origin[f"joints[{n}].axis"] = f"{w}.axis"
            rd.origin[f"joints[{n}].position"] = f"{w}.position"
            if motor:
                seq = jd.get("targetSequence")
                if seq is not None and seq != []:
                    if not isinstance(seq, list):
                        raise rd.error(f"{w}.targetSequence", seq, "a list of time / value pairs")
                    vals = [rd.num({"v": x}, "v", f"{w}.targetSequence[{i}]", 0.0)
                            for i, x in enumerate(seq)]
                    entry["motor"] = {
                        "target_sequence": [x if i % 2 == 0 else -x for i, x in enumerate(vals)],
                        "repeat": rd.flag(jd, "repeatSequence", w, False)}
                    rd.origin[f"joints[{n}].motor.target_sequence"] = f"{w}.targetSequence"
                else:
                    entry["motor"] = {"target_velocity": -rd.num(jd, "target", w, 0.0)}
                    rd.origin[f"joints[{n}].motor"] = f"{w}.target"
            out.append(entry)
    rd.origin["joints"] = "/".join(JOINT_ARRAYS)
    return out
