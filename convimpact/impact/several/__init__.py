"""Step 3b: an impact's several contacts on the contact engine (:mod:`convimpact.contacts`).

* :mod:`.interior`: ``method="interior"`` on an impact problem: the law's program handed to the
  engine, the answer read back as an :class:`~convimpact.impact.results.ImpactResult`;
* :mod:`.law_programs`: the laws' programs (restitution's shift, friction per contact) posed
  and solved in one compiled call;
* :mod:`.lane` and :mod:`.lane_kernel`: the public call's compiled lane for several open-loop
  contacts.
"""
