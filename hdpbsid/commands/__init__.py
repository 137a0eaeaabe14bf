"""The sub-commands of the ``hdpbsid`` command line (parsed and dispatched by :mod:`hdpbsid.cli`).

* :mod:`~hdpbsid.commands.common` -- what every command shares: exit codes, usage errors,
  column lists, ``--out`` checks, the printed model;
* :mod:`~hdpbsid.commands.identify` -- ``hdpbsid identify`` and ``hdpbsid validate``;
* :mod:`~hdpbsid.commands.demo` -- ``hdpbsid demo`` and ``hdpbsid study``.

None of them imports numpy at module level: ``hdpbsid --help`` and a usage error need no
numerical library (:mod:`hdpbsid.cli`).
"""
