"""The bus client: a sans-I/O core of procedures, and sync and asyncio drivers for it."""
