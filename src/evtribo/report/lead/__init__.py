"""What ``evtribo report``'s page leads with: the key results, the warnings grouped by kind
(also ``evtribo analyze``'s console), the cells each warning touches, what was analysed and
left out, and how each subject's numbers were estimated."""

__all__: list[str] = []
