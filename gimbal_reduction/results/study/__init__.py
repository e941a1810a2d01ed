"""The thesis study: its cases, error tables (eq. 3.53), findings, figures, mode shapes and
the Typst report."""
