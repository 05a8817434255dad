"""Post-processing of results: section loads, strains and stresses, joint loads.

Sign convention, for all: the load is the one the outboard side (the
child, with everything it carries) exerts on the inboard side (the parent)
at the joint point; equivalently, minus the load the joint applies to the
child.

Modules
-------
fields
    The named results (:class:`SectionField`, :class:`Envelope`,
    :class:`JointLoads`).
sections
    Section loads, strains and stresses along flexible bodies.
joint_loads
    The force and moment every joint transmits.
motion
    Point positions, velocities and accelerations, body angular velocities.
contact
    Penetration, forces and slip of the contact elements.

The package sits below :mod:`flexmb.result` and :mod:`flexmb.export`: it
reads results and never builds or imports them.
"""

from .._lazy import lazy_names as _lazy_names

# every module of the package is imported where one of its names is first used: a run imports
# flexmb.result, which imports the accessors (``result.post``) but none of these
_LAZY = {
    **dict.fromkeys(("ContactHistory", "contact_history"), ".contact"),
    **dict.fromkeys(("LOAD_COMPONENTS", "Envelope", "JointLoads", "SectionField"), ".fields"),
    **dict.fromkeys(("constraint_loads", "joint_loads"), ".joint_loads"),
    **dict.fromkeys(("angular_velocity", "point_motion"), ".motion"),
    **dict.fromkeys(("joint_stations", "section_loads", "section_strains", "section_stresses"), ".sections"),
}

__getattr__, __dir__ = _lazy_names(globals(), _LAZY)

__all__ = ["SectionField", "Envelope", "JointLoads", "LOAD_COMPONENTS", "section_loads", "section_strains",
           "section_stresses", "joint_loads", "constraint_loads", "joint_stations", "point_motion",
           "angular_velocity", "ContactHistory", "contact_history"]
