// INIT is where the mission starts; no block can run it.
package CallInit

var D1 Quadcopter

func INIT() {
	SEQ_Again()
}

func SEQ_Again() {
	D1.FlyByX(1)
	INIT()
}
