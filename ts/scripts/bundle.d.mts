/** Build the browser bundle (one ESM file) at `outfile`. */
export function bundle(outfile: string): Promise<void>;
