// The entry point has parameters that nothing can supply.
package EntryParams

var D1 Quadcopter

func SEQ_Square(d Quadcopter, side float64) {
	d.FlyByX(side)
}
