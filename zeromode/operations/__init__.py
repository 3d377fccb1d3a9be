"""The library's operations, the one pipeline behind the three doors (REST, jobs and CLI, and
``import zeromode``): ``endpoints`` (each endpoint's operation on its validated request),
``documents`` (documents recognised by their fields), ``prechecks`` (the checks an endpoint makes
before any work), ``plotting`` and ``exporting`` (a document as a picture or a file). It imports
the wire format, viz, export and the solver; nothing of the job engine, the REST layer or the CLI."""
