import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";

export const STATIC = join(dirname(fileURLToPath(import.meta.url)), "../../python/src/nurimc/dashboard/static");
